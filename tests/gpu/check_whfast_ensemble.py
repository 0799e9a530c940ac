"""Run a WHFast ensemble on the CUDA backend (a GPU, or numba's simulator when
NUMBA_ENABLE_CUDASIM=1) beside the same ensemble on the CPU and print ``key=value`` lines."""

from __future__ import annotations

import os
import tempfile

import numpy as np

import visviva as vv


def member(k):
    """Ragged members (3 to 10 particles, a test particle in some), each with its own time step;
    one member is softened, one lands on its output times by grid points only."""
    k6 = k % 6
    rng = np.random.default_rng(k)
    sim = vv.Simulation("whfast", dt=0.01 + 0.002 * k6, softening=0.01 * (k == 3),
                        exact_finish_time=k6 != 4)
    sim.add(1.0)
    # member 7: 10 massive bodies, where the CPU's few-body gravity sums packed rows
    # (gravity.sum_rows) instead of the plain loop the device runs (the same bits)
    for j in range(1, 10 if k == 7 else 3 + k % 3):
        sim.add(1e-3 * rng.uniform(0.1, 1.0), a=1.0 + 0.5 * j, e=0.1 * rng.uniform(),
                inc=0.05 * rng.uniform(), mean_anomaly=rng.uniform(0, 6.28), primary=0)
    if k % 2:
        sim.add(0.0, a=0.6, e=0.2, primary=0)
    sim.move_to_com()
    return sim


def rel(a, b):
    a, b = np.nan_to_num(a), np.nan_to_num(b)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def gravity(sim):
    """The pulls on each particle of ``sim`` (G, masses and softening its own; gravity only)."""
    x, m = sim.positions, sim.masses
    d = x[None, :, :] - x[:, None, :]
    r2 = np.sum(d * d, axis=2) + sim.softening**2
    np.fill_diagonal(r2, np.inf)
    return sim.G * np.sum(m[None, :, None] * d / r2[:, :, None] ** 1.5, axis=1)


def rel_same_time(a, b):
    """How ensemble ``a`` differs from ``b`` carried to ``a``'s times: (positions, velocities),
    relative. Adaptive steps (IAS15's are chosen from a coefficient at the level of round-off)
    can end a member that lands on its output time by its own steps (no exact finish) or stops
    at an event a few 1e-12 of the time away from the CPU's; ``b``'s state is moved by that
    difference to first order (x + v dt, v + a dt; the neglected terms are dt**2 ~ 1e-24)."""
    pos, vel = [], []
    for k in range(len(a.t)):
        dt = a.t[k] - b.t[k]
        ref = b[k]
        x, v = ref.positions, ref.velocities
        pos.append((a[k].positions, x + v * dt))
        vel.append((a[k].velocities, v + gravity(ref) * dt))

    def worst(pairs, scale):
        return max(float(np.max(np.abs(np.nan_to_num(p - q)))) for p, q in pairs) / scale

    return (worst(pos, float(np.max(np.abs(np.nan_to_num(b.positions))))),
            worst(vel, float(np.max(np.abs(np.nan_to_num(b.velocities))))))


def same(a, b):
    return (np.array_equal(a.t, b.t) and bool(np.array_equal(np.nan_to_num(a.positions),
                                                             np.nan_to_num(b.positions)))
            and [s.steps_done for s in a] == [s.steps_done for s in b])


def continue_on(ens, ref, backend, t, key):
    """Save ``ens``, load it on ``backend`` and continue it, and ``ref``, to ``t``; print how
    they differ (keys ``<key>_pos``, ``<key>_vel``, ``<key>_steps_equal``)."""
    path = os.path.join(tempfile.mkdtemp(), "e.npz")
    ens.save(path)
    back = vv.Ensemble.load(path, backend=backend)
    back.integrate(t)
    ref.integrate(t)
    print(f"{key}_pos={rel(back.positions, ref.positions)!r}")
    print(f"{key}_vel={rel(back.velocities, ref.velocities)!r}")
    pos, vel = rel_same_time(back, ref)
    print(f"{key}_pos_same_t={pos!r}")
    print(f"{key}_vel_same_t={vel!r}")
    print(f"{key}_steps_equal={[s.steps_done for s in back] == [s.steps_done for s in ref]!r}")


def each_vs_packed(members, times):
    """The member-by-member GPU path (what runs when the pack cannot) against the packed one."""
    from visviva.nbody.ensemble import _advance_each

    each = vv.Ensemble.from_simulations(members, backend="cuda")
    packed = vv.Ensemble.from_simulations(members, backend="cuda")
    for t in times:
        _advance_each(each._members, t, "cuda")
        packed.integrate(t)
    print(f"each_bits_vs_packed={same(each, packed)!r}")


def main():
    # 20 members: two blocks of threads under the simulator (16 threads per block there)
    members = [member(k) for k in range(20)]
    cpu = vv.Ensemble.from_simulations(members)
    gpu = vv.Ensemble.from_simulations(members, backend="cuda")
    # at the start time (nothing moves), off the grid, on it (t = 0.36 is a grid point of
    # dt = 0.01 and 0.012), backwards (the internal state is built again)
    for t in (0.0, 0.237, 0.36, 0.3):
        cpu.integrate(t)
        gpu.integrate(t)
    print(f"ens_pos={rel(gpu.positions, cpu.positions)!r}")
    print(f"ens_vel={rel(gpu.velocities, cpu.velocities)!r}")
    print(f"ens_t_equal={np.array_equal(gpu.t, cpu.t)!r}")
    print(f"ens_steps_equal={[s.steps_done for s in gpu] == [s.steps_done for s in cpu]!r}")
    print(f"ens_steps={min(s.steps_done for s in gpu)!r}")
    print(f"ens_packed={gpu._pack is not None!r}")

    continue_on(gpu, cpu, "cpu", 0.55, "restart")  # saved on the GPU, continued on the CPU
    each_vs_packed(members, (0.113, 0.2))

if __name__ == "__main__":
    main()
