"""The passive sonar equation for one channel: SNR = SL - TL(r, f) - NL(f, B)  [dB].

SL the modem's source level (dB re 1 uPa at 1 m), TL the transmission loss of `propagation`
at the carrier frequency, NL the ambient noise of `noise` integrated over the modem's band
(Urick 1983, ch. 2; Stojanovic 2007, eq. 7 with the band's noise). With interference, the
signal competes with the noise plus every overlapping frame's received power (SINR, in linear
units). What the receiver makes of a frame at that SNR is the modem's (`modems.Modem`);
fading (`fading`) spreads one frame's SNR around the mean.

`LinkBudget` holds what does not change while a channel runs (absorption, band noise) so that
the per-frame work is a logarithm and an error function.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from comms_sim.acoustics.fading import mean_success
from comms_sim.acoustics.modems import Modem
from comms_sim.acoustics.noise import SeaState, band_noise_db
from comms_sim.acoustics.propagation import REFERENCE_RANGE_M, thorp_db_per_km

# A frame this far under the decoder's noise floor changes a neighbour's SINR by < 0.5 dB.
HEARING_SNR_DB = -10.0
MAX_HEARING_RANGE_M = 200_000.0


@dataclass(frozen=True)
class LinkBudget:
    modem: Modem
    sea: SeaState = SeaState()
    spreading_k: float = 1.5
    absorption_db_per_km: float | None = None  # None: Thorp at the carrier frequency
    bitrate_bps: float = 1000.0
    rician_k: float | None = None  # None: no fading; 0: Rayleigh
    alpha_db_per_km: float = field(init=False)
    noise_db: float = field(init=False)
    _certain: dict[int, tuple[float, float]] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.spreading_k) and 0.0 < self.spreading_k <= 3.0):
            raise ValueError(f"spreading_k must be in (0, 3], got {self.spreading_k!r}")
        a = self.absorption_db_per_km
        if a is not None and not (math.isfinite(a) and a >= 0):
            raise ValueError(f"absorption_db_per_km must be >= 0 or None, got {a!r}")
        if not (math.isfinite(self.bitrate_bps) and self.bitrate_bps > 0):
            raise ValueError(f"bitrate_bps must be > 0, got {self.bitrate_bps!r}")
        k = self.rician_k
        if k is not None and not (math.isfinite(k) and k >= 0):
            raise ValueError(f"rician_k must be >= 0 or None, got {k!r}")
        alpha = thorp_db_per_km(self.modem.frequency_khz) if a is None else a
        object.__setattr__(self, "alpha_db_per_km", alpha)
        object.__setattr__(self, "noise_db", band_noise_db(
            self.modem.frequency_khz, self.modem.bandwidth_khz, self.sea))
        object.__setattr__(self, "_certain", {})

    def transmission_loss_db(self, range_m: float) -> float:
        r = max(range_m, REFERENCE_RANGE_M)
        return self.spreading_k * 10.0 * math.log10(r) + self.alpha_db_per_km * r / 1000.0

    def received_level_db(self, range_m: float) -> float:
        """dB re 1 uPa^2 at the receiver (the mean over fading)."""
        return self.modem.source_level_db - self.transmission_loss_db(range_m)

    def snr_db(self, range_m: float) -> float:
        """Mean in-band SNR at ``range_m`` without interference."""
        return self.received_level_db(range_m) - self.noise_db

    @property
    def decoder_noise_db(self) -> float:
        """The noise floor the decoder works against: band noise plus implementation loss."""
        return self.noise_db + self.modem.implementation_loss_db

    def decoder_snr_db(self, signal_db: float, interference_db: float = -math.inf) -> float:
        """SINR the decoder works with for a received level ``signal_db`` among interference
        of total power ``interference_db`` (dB re 1 uPa^2): S / (L N + I)."""
        floor = 10.0 ** (self.decoder_noise_db / 10.0)
        if interference_db > -math.inf:
            floor += 10.0 ** (interference_db / 10.0)
        return signal_db - 10.0 * math.log10(floor)

    def success(self, decoder_snr_db: float, nbytes: int) -> float:
        """Chance a frame of ``nbytes`` decodes at instantaneous decoder SINR (dB)."""
        return self.success_ratio(10.0 ** (decoder_snr_db / 10.0), nbytes)

    def success_ratio(self, decoder_snr: float, nbytes: int) -> float:
        """`success` for an SINR given as a power ratio (the channel's per-frame path: most
        frames are far from the edge, where no logarithm or error function is needed)."""
        bounds = self._certain.get(nbytes)
        if bounds is None:
            lo_db, hi_db = self._certainty_bounds(nbytes)
            bounds = self._certain[nbytes] = (10.0 ** (lo_db / 10.0), 10.0 ** (hi_db / 10.0))
        if decoder_snr >= bounds[1]:
            return 1.0
        if decoder_snr <= bounds[0]:
            return 0.0
        return self.modem.success(10.0 * math.log10(decoder_snr), nbytes, self.bitrate_bps)

    def _certainty_bounds(self, nbytes: int, eps: float = 1e-15) -> tuple[float, float]:
        """SNRs (dB) below which a frame of ``nbytes`` never decodes and above which it always
        does, to within ``eps``: most frames of a channel are far from the edge, and there the
        error function need not be evaluated (success is non-decreasing in SNR)."""
        def p(snr_db: float) -> float:
            return self.modem.success(snr_db, nbytes, self.bitrate_bps)

        def edge(lo: float, hi: float, above: Callable[[float], bool]) -> float:
            for _ in range(60):
                mid = (lo + hi) / 2.0
                lo, hi = (lo, mid) if above(p(mid)) else (mid, hi)
            return lo if above(p(lo)) else hi

        never = edge(-200.0, 200.0, lambda v: v > eps) if p(-200.0) <= eps else -math.inf
        always = edge(-200.0, 200.0, lambda v: v >= 1.0 - eps) if p(200.0) >= 1.0 - eps \
            else math.inf
        # bisection lands within 4e-16 dB of the edge: step back so "never" and "always" hold
        return never - 1e-9, always + 1e-9

    def delivery_probability(self, range_m: float, nbytes: int = 64) -> float:
        """Expected chance over fading that a frame of ``nbytes`` decodes at ``range_m``
        (no interference, before any fault injection)."""
        mean_db = self.snr_db(range_m) - self.modem.implementation_loss_db
        return mean_success(lambda s: self.success(s, nbytes), mean_db, self.rician_k)

    def hearing_range_m(self, nbytes: int = 64) -> float:
        """Beyond this range a frame neither decodes nor disturbs another: its mean level is
        `HEARING_SNR_DB` under the decoder's noise floor, and even a fade 15 dB up (Rayleigh:
        one frame in 10^13) leaves it a success chance under 1e-9."""
        interference_tl = (self.modem.source_level_db - self.decoder_noise_db
                           - HEARING_SNR_DB)
        return max(self._range_at_tl(interference_tl), self._decoding_range_m(nbytes))

    def _decoding_range_m(self, nbytes: int) -> float:
        headroom = 0.0 if self.rician_k is None else 15.0
        lo, hi = REFERENCE_RANGE_M, MAX_HEARING_RANGE_M
        if self.success(self.snr_db(hi) - self.modem.implementation_loss_db + headroom,
                        nbytes) >= 1e-9:
            return hi
        for _ in range(60):
            mid = math.sqrt(lo * hi)
            snr = self.snr_db(mid) - self.modem.implementation_loss_db + headroom
            lo, hi = (mid, hi) if self.success(snr, nbytes) >= 1e-9 else (lo, mid)
        return hi

    def _range_at_tl(self, tl_db: float) -> float:
        """Range at which TL reaches ``tl_db`` (TL grows with range: bisection)."""
        if self.transmission_loss_db(MAX_HEARING_RANGE_M) <= tl_db:
            return MAX_HEARING_RANGE_M
        lo, hi = REFERENCE_RANGE_M, MAX_HEARING_RANGE_M
        for _ in range(60):
            mid = math.sqrt(lo * hi)
            lo, hi = (mid, hi) if self.transmission_loss_db(mid) < tl_db else (lo, mid)
        return hi


def crossing_range_m(delivery: Callable[[float], float], level: float,
                     max_range_m: float) -> float:
    """The range at which a non-increasing ``delivery(range_m)`` falls to ``level``
    (0 if it starts below, ``max_range_m`` if it never gets there): bisection to 0.1 m."""
    if delivery(0.0) < level:
        return 0.0
    if delivery(max_range_m) >= level:
        return max_range_m
    lo, hi = 0.0, max_range_m
    while hi - lo > 0.1:
        mid = (lo + hi) / 2.0
        lo, hi = (mid, hi) if delivery(mid) >= level else (lo, mid)
    return lo
