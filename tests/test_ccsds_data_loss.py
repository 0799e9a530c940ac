"""Nothing a user gave is lost without a word: NDM/XML attributes the readers do not keep are
named in a warning, a wrong message ``id`` is refused, and a CCSDS writer that fails leaves the
file it was to replace as it was (audit25)."""

import warnings
from pathlib import Path

import pytest

import visviva as vv
from test_ccsds_oem import OEM_KVN
from test_ccsds_opm_omm import OMM_KVN, OPM_KVN
from test_ccsds_tdm import XML as TDM_XML

CDM_KVN = (Path(__file__).parent / "data" / "sample_cdm.kvn").read_text()

# (reader, writer, a message) for every CCSDS message type
MESSAGES = {
    "opm": (vv.read_opm, vv.write_opm, OPM_KVN),
    "omm": (vv.read_omm, vv.write_omm, OMM_KVN),
    "oem": (vv.read_oem, vv.write_oem, OEM_KVN),
    "cdm": (vv.read_cdm, vv.write_cdm, CDM_KVN),
    "tdm": (vv.read_tdm, vv.write_tdm, TDM_XML),
}


def _xml(kind):
    read, write, text = MESSAGES[kind]
    return write(read(text), format="xml")


@pytest.mark.parametrize("kind", MESSAGES)
def test_written_xml_reads_back_without_a_warning(kind):
    # the writer's own attributes (xmlns:xsi, the schema location, id, version, units,
    # USER_DEFINED parameter) are the schema's: no false alarm on a clean round trip
    read = MESSAGES[kind][0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read(_xml(kind))


@pytest.mark.parametrize("kind", MESSAGES)
def test_attributes_the_schema_does_not_define_are_named(kind):
    # (on structure elements and the message element: no record to keep them in)
    read = MESSAGES[kind][0]
    text = _xml(kind).replace("<segment>", '<segment origin="ops">', 1)
    text = text.replace(" id=", ' flavour="mine" id=', 1)
    with pytest.warns(UserWarning, match="not kept") as record:
        read(text)
    message = str(record[0].message)
    for words in ('origin="ops" on <segment>', f'flavour="mine" on <{kind}>'):
        assert words in message


@pytest.mark.parametrize("kind", MESSAGES)
def test_attributes_of_keyword_elements_are_kept_through_an_xml_write(kind, recwarn):
    # they were warned about and dropped on write; each keyword element now keeps its own
    # (Record.attributes) through read -> write of the same XML, and a KVN write says it
    # leaves them out (18th session, ccsdsleft2)
    read, write, _ = MESSAGES[kind]
    text = _xml(kind).replace("<CREATION_DATE>", '<CREATION_DATE zone="UTC">', 1)
    text = text.replace("<ORIGINATOR>", '<ORIGINATOR lang="en" team="nav">', 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        message = read(text)  # nothing lost: no warning
    written = write(message, format="xml")
    assert '<CREATION_DATE zone="UTC">' in written
    assert '<ORIGINATOR lang="en" team="nav">' in written
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert write(read(written), format="xml") == written  # and again, the same text
    with pytest.warns(UserWarning, match='KVN has no place.*CREATION_DATE: zone="UTC"'):
        kvn = write(message, format="kvn")
    assert "zone" not in kvn


@pytest.mark.parametrize(("kind", "tag"), [("oem", "X"), ("oem", "CX_X"), ("tdm", "EPOCH")])
def test_attributes_on_data_lines_are_still_named_as_dropped(kind, tag):
    # an OEM state or covariance, a TDM observation are kept as numbers, not records
    read, write, _ = MESSAGES[kind]
    text = _xml(kind)
    if f"<{tag}>" not in text and f"<{tag} " not in text:
        pytest.skip(f"no <{tag}> in the sample")
    text = text.replace(f"<{tag}", f'<{tag} src="gps"', 1)
    with pytest.warns(UserWarning, match=f'dropped on write.*src="gps" on <{tag}>'):
        message = read(text)
    assert 'src="gps"' not in write(message, format="xml")


def test_attributes_of_the_ndm_wrapper_are_named():
    text = _xml("omm").replace('<?xml version="1.0" encoding="UTF-8"?>\n', "")
    text = f'<ndm batch="7">\n{text}</ndm>\n'
    with pytest.warns(UserWarning, match='batch="7" on <ndm>'):
        omm = vv.read_omm(text)
    assert omm == vv.read_omm(OMM_KVN)


@pytest.mark.parametrize("kind", MESSAGES)
def test_an_id_of_another_message_type_is_refused(kind):
    text = _xml(kind).replace(f'id="CCSDS_{kind.upper()}_VERS"', 'id="CCSDS_AEM_VERS"')
    with pytest.raises(vv.CCSDSFormatError, match=f"CCSDS_{kind.upper()}_VERS"):
        MESSAGES[kind][0](text)


@pytest.mark.parametrize("kind", MESSAGES)
def test_a_failed_write_keeps_the_old_file(kind, tmp_path):
    # a lone surrogate (left by a file decoded with surrogateescape) cannot be written as
    # UTF-8: the writer used to truncate the file first and leave it empty
    read, write, text = MESSAGES[kind]
    message = read(text)
    path = tmp_path / f"message.{kind}"
    write(message, path)
    before = path.read_bytes()
    comments = message.comments["header"] if kind == "omm" else message.header.comments
    comments.append("bad \udc80 byte")
    with pytest.raises(vv.InvalidInputError, match="cannot encode"):
        write(message, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left


@pytest.mark.parametrize(("kind", "tag"), [
    ("opm", "data"), ("opm", "body"), ("opm", "segment"), ("omm", "data"), ("omm", "omm"),
    ("oem", "body"), ("oem", "segment"), ("oem", "stateVector"), ("cdm", "data"),
    ("cdm", "segment"), ("cdm", "body"), ("tdm", "body"), ("tdm", "observation"),
    ("tdm", "tdm")])
def test_xml_comments_outside_a_section_are_kept(kind, tag, recwarn):
    # NDM/XML lets <COMMENT> open an OPM's, OMM's or CDM's <data>; such comments (and those
    # of <body>, <segment>, the message element, an OEM <stateVector>, a TDM <observation>)
    # were dropped without a word. Each joins the section after it, in both formats.
    read, write, _ = MESSAGES[kind]
    text = _xml(kind)
    opening = f'<{tag} ' if tag == kind else f"<{tag}>"
    at = text.index(">", text.rindex(opening) if tag == "stateVector" else text.index(opening))
    text = text[:at + 1] + "<COMMENT>keep me</COMMENT>" + text[at + 1:]
    message = read(text)
    for fmt in ("kvn", "xml"):
        out = write(message, format=fmt)
        assert out.count("keep me") == 1
        assert write(read(out), format=fmt) == out


def test_a_comment_after_the_last_section_is_refused():
    text = _xml("opm").replace("</data>", "<COMMENT>orphan</COMMENT></data>")
    with pytest.raises(vv.CCSDSFormatError, match="belongs to no section"):
        vv.read_opm(text)


@pytest.mark.parametrize("kind", MESSAGES)
def test_text_beside_elements_is_refused(kind):
    # text in an element that holds elements (<body>stray<segment>) was dropped without a word
    text = _xml(kind).replace("<segment>", "<segment>stray note", 1)
    with pytest.raises(vv.CCSDSFormatError, match="stray note"):
        MESSAGES[kind][0](text)


def test_an_ndm_holding_more_than_the_message_read_names_the_rest():
    # read_opm of a combined <ndm> kept the <opm> and dropped an <oem>, a MESSAGE_ID and the
    # comments beside it without a word
    opm = _xml("opm").replace('<?xml version="1.0" encoding="UTF-8"?>\n', "")
    oem = _xml("oem").replace('<?xml version="1.0" encoding="UTF-8"?>\n', "")
    text = (f"<ndm>\n<MESSAGE_ID>NDM-7</MESSAGE_ID>\n<COMMENT>both products</COMMENT>\n"
            f"{opm}{oem}</ndm>\n")
    with pytest.warns(UserWarning, match=r"<MESSAGE_ID> \(line 2\), <COMMENT> \(line 3\), "
                                         r"<oem> \(line \d+\)"):
        message = vv.read_opm(text)
    assert vv.write_opm(message, format="xml") == _xml("opm")
