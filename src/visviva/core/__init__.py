"""Compiled kernels on plain float64 arrays: the expert layer.

Everything here takes and returns float64 arrays in any consistent units (visviva's public layer
uses km, km/s, s, rad, km3/s2) and integer status codes (:mod:`visviva.core.status`) instead of
exceptions. This package imports numpy and numba only; an import-linter contract keeps astropy and
visviva's upper layers out.
"""
