"""Modems: carrier, band, source level and receiver performance, with named presets.

A `Modem` is the physical layer only: what it radiates (source level, band) and what its
receiver makes of a frame at a given SNR (a modulation's error rate in Gaussian noise, or a
measured SNR-to-frame-error table). How long a frame occupies the water (bit rate, preamble,
largest frame) belongs to the channel's link settings (`comms_sim.config.ChannelConfig`),
which the MAC uses too; the bit rate enters the error rate through Eb/N0 = SNR + 10 log10(B/R).

``implementation_loss_db`` is the SNR a real receiver loses against the Gaussian-noise
formulas: multipath spread and Doppler the equaliser does not undo, synchronisation, receiver
noise. The link budget applies it to the noise floor (the receiver decodes as if the noise
were that much louder), not to interference, so that an interferer matters only when it is
loud next to what the receiver already struggles with. It is not measured here: presets
calibrate it where a working range is known, and say so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from comms_sim.acoustics.modulation import ErrorTable, Modulation, frame_success

TABLE = "table"  # `Modem.modulation` when the receiver follows `error_table`


@dataclass(frozen=True)
class Modem:
    name: str
    frequency_khz: float  # carrier (band centre)
    bandwidth_khz: float
    source_level_db: float  # dB re 1 uPa at 1 m
    modulation: str = "bpsk"  # see `Modulation.parse`, or "table"
    coding_gain_db: float = 0.0  # forward error correction, on Eb/N0
    implementation_loss_db: float = 0.0  # see the module docstring
    error_table: ErrorTable | None = None  # with modulation="table"

    def __post_init__(self) -> None:
        for name in ("frequency_khz", "bandwidth_khz"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"modem {name} must be a positive number, got {value!r}")
        if self.frequency_khz < 1.0:
            raise ValueError("Thorp's absorption holds above a few hundred Hz: modem "
                             f"frequency must be >= 1 kHz, got {self.frequency_khz}")
        if not self.frequency_khz - self.bandwidth_khz / 2.0 > 0:
            raise ValueError(f"band {self.bandwidth_khz} kHz around {self.frequency_khz} kHz "
                             "reaches 0 Hz")
        for name in ("source_level_db", "coding_gain_db", "implementation_loss_db"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"modem {name} must be finite")
        if (self.modulation == TABLE) != (self.error_table is not None):
            raise ValueError('an error_table goes with modulation="table" and only with it')
        if self.modulation != TABLE:
            Modulation.parse(self.modulation)  # raises on an unknown name

    def ebn0_db(self, snr_db: float, bitrate_bps: float) -> float:
        """Energy per bit over noise density, after coding gain, at in-band SNR ``snr_db``."""
        processing_db = 10.0 * math.log10(self.bandwidth_khz * 1000.0 / bitrate_bps)
        return snr_db + processing_db + self.coding_gain_db

    def success(self, snr_db: float, nbytes: int, bitrate_bps: float) -> float:
        """Chance a frame of ``nbytes`` decodes at instantaneous in-band SNR ``snr_db`` (the
        SNR the decoder works with: the link budget has taken the implementation loss)."""
        if self.error_table is not None:
            return self.error_table.success(snr_db, nbytes)
        ebn0 = 10.0 ** (self.ebn0_db(snr_db, bitrate_bps) / 10.0)
        return frame_success(_modulation(self.modulation).bit_error_rate(ebn0), 8 * nbytes)


_PARSED: dict[str, Modulation] = {}


def _modulation(name: str) -> Modulation:
    m = _PARSED.get(name)
    if m is None:
        m = _PARSED[name] = Modulation.parse(name)
    return m


# -- presets ---------------------------------------------------------------------------------
# Sources, cited per number below:
# [WHOI]   WHOI Acoustic Communications Group, Micro-Modem page (acomms.whoi.edu/micro-modem):
#          "80-5400 bps"; "PSK BW = 5kHz, FSK BW = 4kHz"; Rate 6 PSK: 490 bps, 6 frames of
#          32 bytes, 2.95 s packet, 3.25 s with probe and null (so ~0.3 s of preamble); "a Rate
#          5 PSK packet has a Burst Rate of ~5000bps".
# [F05]    Freitag et al., "The WHOI Micro-Modem: an acoustic communications and navigation
#          system for multiple platforms", OCEANS 2005: FH-FSK and variable-rate PSK, "four
#          different bands from 3 to 30 kHz".
# [Goby]   goby-acomms MMDriver: Micro-Modem rates 0-5 carry {1, 3, 3, 2, 2, 8} frames of
#          {32, 64, 64, 256, 256, 256} bytes.
# [RA]     ros_acomms (WHOI), ros_acomms_modeling: `sim_packet_performance_node` frame error
#          rate against SNR for rates 1, 3, 5 (tables below, rounded to 3 decimals);
#          `sim_transmission_loss_node` transmits at 185 dB by default; `modem_sim_node` sums
#          overlapping packets' levels incoherently with the ambient noise (as we do).
# [Evo]    EvoLogics S2C R 18/34 datasheet: 18-34 kHz band, up to 13.9 kbit/s, range up to
#          3500 m, instant messages up to 64 bytes (as quoted in the project brief; the
#          datasheet gives transmit power settings, not a source level).

# ros_acomms' Micro-Modem tables [RA]: in-band SNR (dB) -> frame error rate.
MICROMODEM_RATE1_TABLE = ErrorTable(
    (-7.957, -7.604, -7.234, -6.845, -6.444, -6.012),
    (1.0, 0.937, 0.727, 0.170, 0.020, 0.0), frame_bytes=64)  # rate 1: 64-byte frames [Goby]
MICROMODEM_RATE5_TABLE = ErrorTable(
    (3.097, 4.443, 6.015), (1.0, 0.135, 0.0), frame_bytes=256)  # rate 5: 256-byte frames

MODEMS: dict[str, Modem] = {
    # The project's default: coherent BPSK in the Micro-Modem's PSK band (25 kHz centre [F05],
    # 5 kHz [WHOI]) at the class's 185 dB [RA]. Implementation loss CALIBRATED (not measured):
    # 22.6 dB puts 50 % delivery of a 64-byte frame at 2 km on a shrimp-bed reef with Rician
    # fading K = 5 (the channel's default water), the working range of the project's earlier
    # empirical curve (d50 = 2 km). It stands for shallow-water multipath and Doppler a small
    # AUV's PSK receiver does not undo, and a source level below 185 dB.
    "psk_1k": Modem("psk_1k", 25.0, 5.0, 185.0, "bpsk", implementation_loss_db=22.6),
    # WHOI Micro-Modem rate 0: FH-FSK at 80 bps in a 4 kHz band [WHOI], binary FSK detected
    # non-coherently; its convolutional code is not modelled (coding gain 0: conservative).
    "micromodem_rate0": Modem("micromodem_rate0", 25.0, 4.0, 185.0, "bfsk"),
    # Micro-Modem PSK rates 1 and 5 through ros_acomms' SNR tables [RA], no implementation
    # loss: the tables are the modem's own, whatever water they were taken in.
    "micromodem_psk1": Modem("micromodem_psk1", 25.0, 5.0, 185.0, "table",
                             error_table=MICROMODEM_RATE1_TABLE),
    "micromodem_psk5": Modem("micromodem_psk5", 25.0, 5.0, 185.0, "table",
                             error_table=MICROMODEM_RATE5_TABLE),
    # EvoLogics S2C R 18/34 [Evo]: 26 kHz centre, 16 kHz band. Its sweep-spread-carrier
    # waveform is not modelled: QPSK at the full 13.9 kbit/s stands in. Source level ASSUMED
    # 185 dB (none published); implementation loss CALIBRATED to 21.9 dB so that delivery of
    # a 64-byte instant message is 50 % at the published 3500 m in open water (no shrimp,
    # Rician K = 5 as the channel's default).
    "evologics_s2c_18_34": Modem("evologics_s2c_18_34", 26.0, 16.0, 185.0, "qpsk",
                                 implementation_loss_db=21.9),
}
