"""The Micro-Modem NMEA subset: typed sentences survive encode/parse (Hypothesis), and
malformed input raises one error type with a reason a counter can name."""

from __future__ import annotations

import dataclasses
import datetime as dt

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_bus import nmea
from fleet_bus.nmea import NmeaError

address = st.integers(0, nmea.MAX_ADDRESS)
flag = st.booleans()
frame_no = st.integers(1, 64)
data = st.binary(max_size=256)
hhmmss = st.times().map(lambda t: t.strftime("%H%M%S"))
text = st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7e,
                             blacklist_characters=",*$"), max_size=40)
finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e9, max_value=1e9)
utc = st.datetimes(min_value=dt.datetime(1971, 1, 1), max_value=dt.datetime(2200, 1, 1),
                   timezones=st.just(dt.timezone.utc))

typed = st.one_of(
    st.builds(nmea.CycleInit, st.sampled_from(["CC", "CA"]), address, address,
              st.integers(0, 15), flag, st.integers(0, 64)),
    st.builds(nmea.DataRequest, hhmmss, address, address, flag, st.integers(0, 4096),
              frame_no),
    st.builds(nmea.TxData, address, address, flag, data),
    st.builds(nmea.TxDataEcho, address, address, flag, st.integers(0, 4096)),
    st.builds(nmea.RxData, address, address, flag, frame_no, data),
    st.builds(nmea.TxEdge, flag, st.integers(0, 1 << 16)),
    st.builds(nmea.Ack, address, address, frame_no),
    st.builds(nmea.Config, st.sampled_from(["CC", "CA"]),
              st.from_regex(r"[A-Za-z][A-Za-z0-9_.]{0,31}", fullmatch=True), text),
    st.builds(nmea.ConfigQuery, st.from_regex(r"[A-Z]{3}", fullmatch=True)),
    st.builds(nmea.Clock, st.sampled_from(["CC", "CA"]), utc.map(lambda d: d.replace(
        microsecond=0))),
    st.builds(nmea.Revision, hhmmss, st.sampled_from(["AUV", "INIT"]), text),
    st.builds(nmea.ModemError, hhmmss, st.sampled_from(["NMEA", "DATA_TIMEOUT", "CYC"]),
              st.integers(-1000, 1000), text),
    st.builds(nmea.Ping, st.sampled_from(["CC", "CA"]), address, address),
    st.builds(nmea.Ping, st.just("CA"), address, address, st.just(True)),
    st.builds(nmea.PingReply, address, address,
              st.integers(0, 10**7).map(lambda n: n / 10**4)),
    st.builds(nmea.Place, st.tuples(finite, finite, finite)),
    st.builds(nmea.CycleStats, utc, st.integers(0, 6), address, address, st.integers(0, 8),
              st.integers(0, 8), st.integers(0, 2),
              *[st.integers(-9999, 9999).map(lambda n: n / 100) for _ in range(5)]),
)


@given(typed)
def test_every_typed_sentence_round_trips(message) -> None:
    line = nmea.encode(message)
    assert line.endswith(b"\r\n") and len(line) <= nmea.MAX_LINE_CHARS + 2
    assert nmea.decode(line) == message
    assert nmea.decode(line.rstrip()) == message  # the end of line is optional


@given(typed, st.data())
def test_any_flipped_character_is_caught(message, draw) -> None:
    # NMEA's XOR checksum catches every single-character change (a changed byte changes
    # the XOR); a change may also break the framing first: either way an NmeaError.
    line = bytearray(nmea.encode(message).rstrip())
    i = draw.draw(st.integers(1, len(line) - 4))  # inside the body
    new = draw.draw(st.integers(0x20, 0x7e).filter(lambda c: c != line[i]))
    line[i] = new
    with pytest.raises(NmeaError):
        nmea.decode(bytes(line))


@given(st.binary(max_size=2048))
def test_garbage_raises_only_nmea_errors(blob) -> None:
    try:
        nmea.decode(blob)
    except NmeaError as exc:
        assert exc.reason in nmea.REASONS


def test_the_checksum_is_nmea_0183s_xor() -> None:
    # A sentence quoted in WHOI's acomms tests/logs: XOR of the body, upper-case hex.
    assert nmea.checksum("CCCYC,0,1,2,1,0,3") == "58"
    assert nmea.encode(nmea.CycleInit("CC", 1, 2, 1, False, 3)) == b"$CCCYC,0,1,2,1,0,3*58\r\n"
    assert nmea.parse("$CCCYC,0,1,2,1,0,3*58").kind == "CCCYC"
    assert nmea.parse("$CCCYC,0,1,2,1,0,3*58").fields[1] == "1"


@pytest.mark.parametrize(("line", "reason"), [
    ("$CCCYC,0,1,2,1,0,3*59", "checksum"),
    ("$CCCYC,0,1,2,1,0,3", "no_checksum"),
    ("CCCYC,0,1,2,1,0,3*58", "no_start"),
    ("$" + "A" * 2000 + "*00", "too_long"),
    (b"$CC\xffYC*00", "not_ascii"),
    ("$CCCYC,0,1\x07*00", "not_ascii"),
    ("$CCCYC,0,1,2,1*" + nmea.checksum("CCCYC,0,1,2,1"), "fields"),
    ("$CCTXD,1,2,0,ABC*" + nmea.checksum("CCTXD,1,2,0,ABC"), "hex"),
    ("$CCTXD,1,2,0,ZZ*" + nmea.checksum("CCTXD,1,2,0,ZZ"), "hex"),
    ("$CCCYC,0,x,2,1,0,3*" + nmea.checksum("CCCYC,0,x,2,1,0,3"), "number"),
    ("$CCCYC,0,200,2,1,0,3*" + nmea.checksum("CCCYC,0,200,2,1,0,3"), "value"),
    ("$CCCYC,0,1,2,1,7,3*" + nmea.checksum("CCCYC,0,1,2,1,7,3"), "value"),
    ("$PCFLP,1,nan,2*" + nmea.checksum("PCFLP,1,nan,2"), "number"),
    ("$cccyc*" + nmea.checksum("cccyc"), "fields"),
])
def test_malformed_lines_name_their_reason(line, reason) -> None:
    with pytest.raises(NmeaError) as err:
        nmea.decode(line)
    assert err.value.reason == reason


def test_unknown_sentences_parse_but_are_not_typed() -> None:
    line = nmea.Sentence("CAXST", ("8", "20240101")).encode()
    assert nmea.decode(line) == nmea.Sentence("CAXST", ("8", "20240101"))


def test_cycle_stats_read_by_acomms_as_we_wrote_them() -> None:
    acomms = pytest.importorskip("acomms.cyclestats", reason="WHOI acomms (test extra)")
    from acomms.micromodem import Message

    toa = dt.datetime(2024, 5, 6, 7, 8, 9, 250000, tzinfo=dt.timezone.utc)
    line = nmea.encode(nmea.CycleStats(toa, 1, 3, 0, 2, snr_in=11.5, snr_out=9.25))
    cst = acomms.CycleStats.from_nmea_msg(Message(line.decode()))
    assert (cst["toa"], cst["rate_num"], cst["src"], cst["dest"], cst["num_frames"],
            cst["bad_frames_num"], cst["snr_in"], cst["snr_out"]) == (
        toa.replace(tzinfo=None), 1, 3, 0, 2, 0, 11.5, 9.25)


def test_the_rate_table_follows_goby_and_acomms() -> None:
    # Goby MMDriver PACKET_FRAME_COUNT / PACKET_SIZE for rates 0-5
    assert [nmea.RATES[r].frames for r in range(6)] == [1, 3, 3, 2, 2, 8]
    assert [nmea.RATES[r].frame_bytes for r in range(6)] == [32, 64, 64, 256, 256, 256]
    assert nmea.RATES[0].bit_rate_bps == 80.0 and nmea.RATES[6].packet_bytes == 192


def test_every_field_of_a_cycle_statistic_comes_back_as_itself() -> None:
    """Each field distinct, so that a field read into another's place shows."""
    names = [f.name for f in dataclasses.fields(nmea.CycleStats)
             if f.name not in ("toa", "version", "talker")]
    values = {name: (i + 1) * 1.25 if name in nmea._CST_FLOATS else i + 1
              for i, name in enumerate(names)}
    toa = dt.datetime(2024, 5, 6, 7, 8, 9, 250000, tzinfo=dt.timezone.utc)
    stats = nmea.CycleStats(toa=toa, **values)
    assert nmea.decode(nmea.encode(stats)) == stats
