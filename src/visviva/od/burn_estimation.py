"""Burns in a batch fit (:func:`visviva.fit_orbit`): which impulses' Δvs are estimated, the
refusal of a Δv the data cannot see, and the known impulses' execution errors as consider
parameters (the a priori rows of the plans are :func:`visviva.od.priors.maneuver_priors`).

An estimated impulse's Δv (3 components on its own axes) adds the columns H S_k of the
measurements' partials on it (S_k = d y / d Δv_k, :mod:`visviva.satellites.burn_partials`); a
planned burn's execution covariance C adds the whitened rows W (Δv_plan - Δv), W^T W = C^-1
(Tapley, Schutz & Born 2004, sec. 4.6). A known impulse with an execution covariance that the
data see is a consider parameter (Tapley et al., sec. 6.3): the estimate's sensitivity to its
Δv is S_b = -P A^T A_b and its covariance gains S_b C S_b^T.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["considered_burns", "estimated", "columns", "check_observable", "check_separable"]


def considered_burns(dyn, flown, chosen, H, use, sig, A, P):
    """The known impulses with an execution covariance that the data see (indices into
    ``flown``) and the estimate's sensitivity to their Δvs, S_b = -P A^T A_b (n, 3 q), A_b the
    whitened partials of the measurements on them: their execution errors are consider
    parameters of the fit (:mod:`visviva.od.parameters`)."""
    from ..satellites.burns import ImpulsiveBurn

    known = [i for i, b in enumerate(flown) if i not in chosen
             and isinstance(b, ImpulsiveBurn) and b.execution_covariance is not None]
    if not known:
        return [], np.zeros((P.shape[0], 0))
    hs = H @ dyn.sensitivity[..., columns(dyn.schedule, [flown[i] for i in known])]
    seen = [i for j, i in enumerate(known) if np.any(hs[:, :, 3 * j:3 * j + 3])]
    if not seen:  # every such burn past the data (or before the epoch with none before it)
        return [], np.zeros((P.shape[0], 0))
    cols = np.concatenate([3 * known.index(i) + np.arange(3) for i in seen])
    ab = hs[..., cols][use] / np.broadcast_to(sig, use.shape)[use][:, None]
    ab = np.vstack([ab, np.zeros((A.shape[0] - ab.shape[0], ab.shape[1]))])  # a priori rows
    return seen, -P @ (A.T @ ab)


def estimated(burns, estimate):
    """The indices of the burns whose Δv :func:`fit_orbit` estimates (``estimate_maneuvers``)."""
    from ..satellites.burns import ImpulsiveBurn

    if estimate is None or estimate is False:
        return []
    if estimate is True:
        chosen = [i for i, b in enumerate(burns) if isinstance(b, ImpulsiveBurn)]
        if not chosen:
            raise InvalidInputError(
                "estimate_maneuvers=True but maneuvers= holds no vv.ImpulsiveBurn; give the "
                "burns to estimate (their delta_v is the starting value, e.g. zero).")
        return chosen
    given = list(estimate) if isinstance(estimate, list | tuple | np.ndarray) else None
    # a float or a bool was truncated to an index (1.7 -> 1, [True] -> 1): another burn's Δv
    # estimated in silence; only integers are indices
    if given is None or not all(isinstance(i, int | np.integer)
                                and not isinstance(i, bool | np.bool_) for i in given):
        raise InvalidInputError(
            f"estimate_maneuvers must be True, False/None or a list of integer indices into "
            f"maneuvers; got {estimate!r}.")
    chosen = [int(i) for i in given]
    for i in chosen:
        if not 0 <= i < len(burns):
            raise InvalidInputError(
                f"estimate_maneuvers: index {i} is not one of the {len(burns)} maneuvers.")
        if not isinstance(burns[i], ImpulsiveBurn):
            raise InvalidInputError(
                f"estimate_maneuvers: maneuvers[{i}] is {burns[i]!r}; only an ImpulsiveBurn's "
                "Δv is estimated (a finite burn's thrust is not a solve-for parameter).")
    if len(set(chosen)) != len(chosen):
        raise InvalidInputError(f"estimate_maneuvers lists a burn twice: {chosen}.")
    return chosen


def columns(schedule, flown):
    """The columns of ``Dynamics.sensitivity`` that belong to the burns ``flown``."""
    from ..satellites.burn_partials import impulses_of

    order = [id(m) for m in impulses_of(schedule)]
    return np.concatenate([3 * order.index(id(m)) + np.arange(3) for m in flown])


def check_observable(sens, burns, chosen, priors=()):
    """Refuse an estimated burn that no observation follows (its Δv has no information) and
    no a priori constrains. ``sens`` (N, 3, 3 m): the partials of the measurements on the Δvs
    (a position fix at the burn's own time sees none of it, though the state's do)."""
    constrained = _constrained(priors)
    for j, (burn, i) in enumerate(zip(burns, chosen, strict=True)):
        if j not in constrained and not np.any(sens[:, :, 3 * j:3 * j + 3]):
            raise InvalidInputError(
                f"maneuvers[{i}] ({burn!r}) has no observation after it (or before it, for a "
                "burn before the epoch) that its Δv changes: its Δv cannot be estimated from "
                "these data. Drop it from estimate_maneuvers, add tracking past it, or give the "
                "burn its execution error (delta_v_covariance=...) as an a priori.")


def check_separable(schedule, burns, chosen, priors, offsets):
    """Refuse estimated Δvs that the data cannot tell from the state or from each other, with
    no a priori to separate them: a burn at the estimate's epoch with no observation before it
    (its Δv and the epoch velocity are one unknown), two burns at the same time (only their
    sum is seen)."""
    constrained = {chosen[j] for j in _constrained(priors)}
    at = {id(m): a for a, _, m in schedule.items} if schedule else {}
    free = [i for i in chosen if i not in constrained]
    for i in free:
        if at[id(burns[i])] == 0.0 and not np.any(offsets < 0.0):
            raise InvalidInputError(
                f"maneuvers[{i}] ({burns[i]!r}) is at the estimate's epoch and no observation "
                "precedes it: its Δv and the epoch's velocity are one unknown. Give initial an "
                "epoch before the burn, hold the burn known, or give it its execution error "
                "(delta_v_covariance=...) as an a priori.")
    for n, i in enumerate(free):
        for k in free[n + 1:]:
            if at[id(burns[i])] == at[id(burns[k])]:
                raise InvalidInputError(
                    f"maneuvers[{i}] and maneuvers[{k}] are estimated at the same time: the "
                    "data see only their sum. Estimate one of them (the other known), or give "
                    "them execution errors (delta_v_covariance=...) as a priori.")


def _constrained(priors):
    """The positions (in the estimated list) of the burns whose Δv has an a priori: the priors
    are (first column, W, value) of :func:`visviva.od.priors.maneuver_priors`, a burn's columns
    following the 6 of the state, 3 each."""
    return {(col - 6) // 3 for col, _, _ in priors if col >= 6}
