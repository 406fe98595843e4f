"""Bit and frame error rates: what a receiver makes of a frame at a given SNR.

Two ways, as the simulators users know do it:

- from the modulation's bit error rate in white Gaussian noise (UnetStack's approach), with
  the energy per bit over the noise density taken from the in-band SNR as

      Eb/N0 = SNR + 10 log10(B / R) + coding gain    [dB]

  (B the band, R the bit rate: spreading a bit over more bandwidth is processing gain), and
  the bit errors independent, so a frame of n bits survives with (1 - BER)^n;
- from a measured table of frame error rate against SNR, one per modem rate, interpolated
  linearly in dB and clamped at the ends (ros_acomms' `sim_packet_performance_node` keeps the
  WHOI Micro-Modem's this way).

Bit error rates (J. G. Proakis, *Digital Communications*, 4th ed., 2001, sec. 5.2):

- coherent BPSK and Gray-coded QPSK: Q(sqrt(2 Eb/N0)), Q the Gaussian tail;
- coherent M-PSK, M >= 8 (Gray, nearest-neighbour approximation):
  (2 / log2 M) Q(sqrt(2 log2(M) Eb/N0) sin(pi / M));
- non-coherent M-FSK (orthogonal tones, envelope detection), symbol error
  P_M = sum_{n=1}^{M-1} (-1)^{n+1} C(M-1, n) / (n+1) exp(-n log2(M) Eb/N0 / (n+1)),
  bit error P_M (M/2) / (M-1); for BFSK this is 0.5 exp(-Eb / 2N0).
"""

from __future__ import annotations

import bisect
import math
import re
from dataclasses import dataclass

_NAME = re.compile(r"^(b|q|\d+)(psk|fsk)$")


@dataclass(frozen=True)
class Modulation:
    """``kind`` "psk" (coherent) or "fsk" (non-coherent), ``order`` M (a power of 2)."""

    kind: str
    order: int

    def __post_init__(self) -> None:
        if self.kind not in ("psk", "fsk"):
            raise ValueError(f"modulation kind must be psk or fsk, got {self.kind!r}")
        if self.order < 2 or self.order & (self.order - 1):
            raise ValueError(f"modulation order must be a power of 2 >= 2, got {self.order}")

    @staticmethod
    def parse(name: str) -> "Modulation":
        """"bpsk", "qpsk", "8psk", "bfsk", "4fsk", "16fsk", ..."""
        m = _NAME.match(name.strip().lower())
        if m is None:
            raise ValueError(f"unknown modulation {name!r}: use bpsk, qpsk, 8psk, bfsk, 4fsk...")
        order = {"b": 2, "q": 4}.get(m.group(1)) or int(m.group(1))
        return Modulation(m.group(2), order)

    @property
    def bits_per_symbol(self) -> int:
        return self.order.bit_length() - 1

    def bit_error_rate(self, ebn0: float) -> float:
        """BER at ``ebn0`` (linear Eb/N0 >= 0)."""
        k = self.bits_per_symbol
        if self.kind == "psk":
            if self.order <= 4:
                return q_function(math.sqrt(2.0 * ebn0))
            return min(0.5, 2.0 / k * q_function(
                math.sqrt(2.0 * k * ebn0) * math.sin(math.pi / self.order)))
        m = self.order
        symbol_error = sum((-1) ** (n + 1) * math.comb(m - 1, n) / (n + 1)
                           * math.exp(-n * k * ebn0 / (n + 1)) for n in range(1, m))
        return min(0.5, max(0.0, symbol_error * (m / 2.0) / (m - 1)))


def q_function(x: float) -> float:
    """Gaussian tail probability P(N(0, 1) > x)."""
    return 0.5 * math.erfc(x / math.sqrt(2.0))


def frame_success(ber: float, nbits: int) -> float:
    """Probability that ``nbits`` independent bits all arrive right."""
    if ber >= 1.0:
        return 0.0
    return math.exp(nbits * math.log1p(-ber))


@dataclass(frozen=True)
class ErrorTable:
    """Measured frame error rate against in-band SNR for one modem rate.

    ``snr_db`` ascending; ``frame_error`` the matching frame error rates (clamped at the ends,
    interpolated linearly in between); ``frame_bytes`` the modem's frame size: a message of n
    bytes takes ceil(n / frame_bytes) frames, all of which must arrive."""

    snr_db: tuple[float, ...]
    frame_error: tuple[float, ...]
    frame_bytes: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "snr_db", tuple(float(x) for x in self.snr_db))
        object.__setattr__(self, "frame_error", tuple(float(x) for x in self.frame_error))
        if len(self.snr_db) < 2 or len(self.snr_db) != len(self.frame_error):
            raise ValueError("an error table needs at least two (snr_db, frame_error) points")
        if any(b <= a for a, b in zip(self.snr_db, self.snr_db[1:])):
            raise ValueError(f"error table SNRs must increase: {self.snr_db}")
        if any(not 0.0 <= p <= 1.0 for p in self.frame_error):
            raise ValueError(f"frame error rates must be in [0, 1]: {self.frame_error}")
        if any(b > a for a, b in zip(self.frame_error, self.frame_error[1:])):
            raise ValueError("frame error must not grow with SNR (delivery would not fall "
                             f"monotonically with range): {self.frame_error}")
        if not (isinstance(self.frame_bytes, int) and self.frame_bytes > 0):
            raise ValueError(f"frame_bytes must be a positive int, got {self.frame_bytes!r}")

    def frame_error_at(self, snr_db: float) -> float:
        xs, ys = self.snr_db, self.frame_error
        if snr_db <= xs[0]:
            return ys[0]
        if snr_db >= xs[-1]:
            return ys[-1]
        i = bisect.bisect_right(xs, snr_db)
        t = (snr_db - xs[i - 1]) / (xs[i] - xs[i - 1])
        return ys[i - 1] + t * (ys[i] - ys[i - 1])

    def success(self, snr_db: float, nbytes: int) -> float:
        frames = max(1, -(-nbytes // self.frame_bytes))
        return (1.0 - self.frame_error_at(snr_db)) ** frames
