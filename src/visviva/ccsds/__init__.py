"""CCSDS Navigation Data Messages: one grammar (KVN and XML) shared by OEM, OPM, OMM and CDM.

The modules, bottom up:

* :mod:`~visviva.ccsds.grammar` -- :class:`~visviva.ccsds.grammar.CCSDSFormatError` (names the
  line), :class:`~visviva.ccsds.grammar.Keyword` (name, type, unit, mandatory flag),
  :class:`~visviva.ccsds.grammar.Section` (a tuple of keywords and its XML path),
  :class:`~visviva.ccsds.grammar.Record` (the values of one section as read, with comments and
  line numbers), ``parse_value``/``format_value`` (types and units checked, floats written so
  they read back bit for bit);
* :mod:`~visviva.ccsds.kvn` -- the KVN lexer (``tokenize``: keyword, comment, block-marker and
  data lines, each with its line number), a cursor with the verbs readers need
  (``take_comments``, ``expect_block``, ``data_lines``, ``error``) and ``KVNWriter``;
* :mod:`~visviva.ccsds.ndmxml` -- an XML element tree that keeps line numbers (expat) and the
  NDM/XML writer helpers (``new_root``, ``add_text``, ``to_text``);
* :mod:`~visviva.ccsds.layout` -- reading and writing sections from their description, in KVN
  (``read_kvn_section``/``write_kvn_section``) and XML (``read_xml_section``/
  ``write_xml_section``), and whole flat messages (``read_message``/``write_message``);
* :mod:`~visviva.ccsds.timeframes` -- epochs and ``TIME_SYSTEM`` to astropy ``Time``,
  ``REF_FRAME`` to visviva's frames, ``CENTER_NAME`` to bodies;
* the messages: :mod:`~visviva.ccsds.oem` (``Ephemeris``, ``OEMSegment``, interpolation in
  :mod:`~visviva.ccsds.interpolation`) with :mod:`~visviva.ccsds.oem_io`,
  :mod:`~visviva.ccsds.opm`, :mod:`~visviva.ccsds.omm`, the tracking data message
  :mod:`~visviva.ccsds.tdm` with :mod:`~visviva.ccsds.tdm_write` (its meaning for orbit
  determination is :mod:`visviva.od.tracking_data`, which ``vv.read_tdm`` uses);
  ``visviva convert`` in :mod:`~visviva.ccsds.convert`.

How a message is described and read (the pattern the OPM, OMM and CDM modules follow)::

    from visviva.ccsds.grammar import Keyword as K, Section
    from visviva.ccsds.layout import read_message, write_message

    HEADER = Section("header", (
        K("CCSDS_XXX_VERS", "text", None, True), K("CREATION_DATE", "epoch", None, True),
        K("ORIGINATOR", "text", None, True), K("MESSAGE_ID")), "header")
    STATE = Section("state_vector", (
        K("EPOCH", "epoch", None, True), K("X", "float", "km", True), ...),
        "body/segment/data/stateVector")
    parsed, fmt, name = read_message(text_or_path, (HEADER, STATE), "xxx", "CCSDS_XXX_VERS")
    parsed["state_vector"]["X"]          # a float; parsed[...].lines["X"] is its line
    text = write_message(parsed, (HEADER, STATE), "xxx", "CCSDS_XXX_VERS", fmt="xml")

A message whose KVN has blocks (the OEM's ``META_START`` ... ``META_STOP``, data lines,
``COVARIANCE_START`` ... ``COVARIANCE_STOP``) walks a :class:`~visviva.ccsds.kvn.KVNCursor`
itself and calls ``read_kvn_section`` for each keyword block; in XML it takes the nodes with
``XMLNode.path`` and calls ``read_xml_section``. Every reader raises
:class:`~visviva.ccsds.grammar.CCSDSFormatError` (a :class:`visviva.errors.InvalidInputError`)
with ``source, line N: what is wrong``.
"""

from .grammar import CCSDSFormatError, Keyword, Record, Section
from .oem import Ephemeris, OEMCovariance, OEMSegment
from .oem_io import read_oem, write_oem
from .omm import OMM, read_omm, write_omm
from .opm import OPM, Maneuver, read_opm, write_opm
from .tdm import TDMSegment
from .tdm_write import write_tdm

__all__ = ["CCSDSFormatError", "Keyword", "Record", "Section", "Ephemeris", "OEMSegment",
           "OEMCovariance", "OPM", "Maneuver", "OMM", "read_oem", "write_oem", "read_opm",
           "write_opm", "read_omm", "write_omm", "TDMSegment", "write_tdm"]
