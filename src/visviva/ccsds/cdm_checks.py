"""Checks of a CDM as read that need no section table: the CDM 2.0 alternate covariance
(refused, never left out) and the two objects' frames (warned about when they differ)."""

from __future__ import annotations

from .grammar import CCSDSFormatError

__all__ = ["alt_covariance", "check_segment_elements", "check_frames"]

#: CDM 2.0 keywords (and XML elements) of the alternate covariance, which visviva does not read:
#: refused rather than left out (ALT_COV_TYPE = XYZ gives CX_X ... in ALT_COV_REF_FRAME,
#: CSIG3EIGVEC3 sigmas and eigenvectors)
_ALT_COVARIANCE = ("ALT_COV_TYPE", "ALT_COV_REF_FRAME", "CSIG3EIGVEC3", "CX_X")


def alt_covariance(key) -> str | None:
    """Why ``key`` is refused when it is part of the CDM 2.0 alternate covariance, else None."""
    if key not in _ALT_COVARIANCE:
        return None
    return (f"{key} belongs to the CDM 2.0 alternate covariance (ALT_COV_TYPE = XYZ or "
            "CSIG3EIGVEC3), which visviva does not read; it reads the RTN covariance (CR_R ... "
            "CNDOT_NDOT, mandatory in CDM 1.0): give the covariance in RTN")


def check_segment_elements(segment, sections, name: str) -> None:
    """Refuse an element of a ``<segment>`` that no section reads (it was left out silently:
    a CDM 2.0 alternate covariance beside the RTN one, a misspelt ``<stateVektor>``),
    naming it and its line (``sections``: those of a segment)."""
    from .layout import check_xml_elements

    def alt(node):
        for child in node.children:
            why = alt_covariance(child.tag)
            if why:
                raise CCSDSFormatError(why, line=child.line, source=name)
            alt(child)

    alt(segment)
    check_xml_elements(segment, sections, name)


def check_frames(sections: dict, source: str) -> None:
    """Warn when the two objects' states are on different axes (508.0-B-1 lets each segment
    name its REF_FRAME): ``collision_probability(o1.r, o1.v, o1.covariance, o2.r, ...)``
    takes both in one frame, and EME2000 beside ITRF puts them thousands of km apart."""
    import warnings

    from .timeframes import visviva_frame

    meta = [sections[k]["metadata"] for k in ("object1", "object2")]
    names = [str(m["REF_FRAME"]).strip().upper() for m in meta]
    kinds = [visviva_frame(n) or n for n in names]
    if kinds[0] != kinds[1]:
        warnings.warn(
            f"{source}, line {meta[1].line_of('REF_FRAME')}: OBJECT2's state is in REF_FRAME = "
            f"{names[1]}, OBJECT1's in {names[0]} (line {meta[0].line_of('REF_FRAME')}): "
            "msg.states() and msg.probability(hbr) put both on GCRF; o1.r - o2.r, or "
            "collision_probability(o1.r, ..., o2.r, ...) as written, mixes the two frames.",
            UserWarning, stacklevel=4)
