"""The physics of `comms_sim.acoustics` against values worked out by hand from the formulas
(Thorp, Stojanovic's noise spectra, Proakis' error rates) and against closed forms the code
does not use (fading averages)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from comms_sim.acoustics.budget import HEARING_SNR_DB, LinkBudget
from comms_sim.acoustics.fading import mean_success, power_gain
from comms_sim.acoustics.modems import MICROMODEM_RATE1_TABLE, MODEMS, Modem
from comms_sim.acoustics.modulation import ErrorTable, Modulation, frame_success, q_function
from comms_sim.acoustics.noise import (SHRIMP_BED_DB, SeaState, band_noise_db, noise_psd_db,
                                       wind_db)
from comms_sim.acoustics.propagation import thorp_db_per_km, transmission_loss_db

OPEN_SEA = SeaState(wind_mps=5.0, shipping=0.5)


# -- propagation ------------------------------------------------------------------------------

@pytest.mark.parametrize("f_khz, alpha", [
    (1.0, 0.069004),    # 0.11/2 + 44/4101 + 2.75e-4 + 0.003
    (10.0, 1.18703),    # 11/101 + 4400/4200 + 0.0275 + 0.003
    (25.0, 6.104805),   # 68.75/626 + 27500/4725 + 0.171875 + 0.003
    (40.0, 12.903808),  # 176/1601 + 70400/5700 + 0.44 + 0.003
    (100.0, 34.068663), # 1100/10001 + 440000/14100 + 2.75 + 0.003
])
def test_thorp_absorption(f_khz: float, alpha: float) -> None:
    assert thorp_db_per_km(f_khz) == pytest.approx(alpha, abs=1e-6)


@pytest.mark.parametrize("range_m, f_khz, k, tl", [
    (1000.0, 25.0, 1.5, 45.0 + 6.104805),                 # 15 log10(1000) + alpha(25) * 1
    (100.0, 10.0, 1.5, 30.0 + 0.118703),                  # 15 log10(100) + alpha(10) * 0.1
    (5000.0, 40.0, 1.5, 55.484550 + 64.519040),           # 15 log10(5000) + alpha(40) * 5
    (2000.0, 12.0, 2.0, 69.310145),                       # spherical: 20 log10(2000) + ...
    (0.2, 25.0, 1.5, 6.104805e-3),                        # under 1 m counts as 1 m
])
def test_transmission_loss(range_m: float, f_khz: float, k: float, tl: float) -> None:
    assert transmission_loss_db(range_m, f_khz, k) == pytest.approx(tl, abs=1e-5)


def test_transmission_loss_with_given_absorption() -> None:
    assert transmission_loss_db(3000.0, 25.0, 1.5, absorption_db_per_km=2.0) == \
        pytest.approx(15.0 * math.log10(3000.0) + 6.0)
    with pytest.raises(ValueError):
        thorp_db_per_km(0.0)


# -- noise ------------------------------------------------------------------------------------

@pytest.mark.parametrize("f_khz, wind, shipping, psd", [
    (25.0, 5.0, 0.5, 38.548078),   # wind term 38.53 dominates
    (10.0, 0.0, 0.5, 29.354704),   # calm: wind 50 + 20 - 41.5, shipping and thermal below
    (1.0, 10.0, 1.0, 67.930964),   # low frequency, heavy shipping and a strong wind
    (50.0, 15.0, 0.0, 44.940575),
    (25.0, 0.0, 0.0, 22.303003),
])
def test_noise_psd_at_frequencies_and_winds(f_khz: float, wind: float, shipping: float,
                                            psd: float) -> None:
    assert noise_psd_db(f_khz, SeaState(wind, shipping)) == pytest.approx(psd, abs=1e-5)


def test_wind_raises_the_noise_the_way_stojanovic_says() -> None:
    # 7.5 sqrt(w): from 4 to 16 m/s the wind term grows by 7.5 * (4 - 2) = 15 dB
    assert wind_db(25.0, 16.0) - wind_db(25.0, 4.0) == pytest.approx(15.0)
    low, high = (noise_psd_db(25.0, SeaState(w)) for w in (4.0, 16.0))
    assert 14.0 < high - low < 15.0  # the other terms add a little at 4 m/s


def _psd_by_hand(f: float, sea: SeaState) -> float:
    terms = (17 - 30 * math.log10(f),
             40 + 20 * (sea.shipping - 0.5) + 26 * math.log10(f) - 60 * math.log10(f + 0.03),
             50 + 7.5 * math.sqrt(sea.wind_mps) + 20 * math.log10(f) - 40 * math.log10(f + 0.4),
             -15 + 20 * math.log10(f), sea.shrimp_db)
    return sum(10 ** (t / 10) for t in terms)


@pytest.mark.parametrize("centre, band, sea", [
    (25.0, 5.0, OPEN_SEA), (26.0, 16.0, SeaState(wind_mps=10.0, shipping=0.2)),
    (3.0, 4.0, SeaState(shipping=1.0)), (25.0, 4.0, SeaState(shrimp_db=SHRIMP_BED_DB)),
])
def test_band_noise_is_the_integral_of_the_psd(centre: float, band: float,
                                               sea: SeaState) -> None:
    """Midpoint sum on 20 000 cells, against the code's 65-point Simpson rule."""
    edges = np.linspace(centre - band / 2, centre + band / 2, 20_001)
    mids = (edges[:-1] + edges[1:]) / 2
    power = sum(_psd_by_hand(f, sea) for f in mids) * (edges[1] - edges[0]) * 1000.0
    assert band_noise_db(centre, band, sea) == pytest.approx(10 * math.log10(power), abs=1e-3)
    # a narrow band is the PSD times its width
    assert band_noise_db(centre, 0.001, sea) == pytest.approx(
        10 * math.log10(_psd_by_hand(centre, sea)) + 0.0, abs=1e-4)


def test_shrimp_bed_is_everest_figure() -> None:
    """25 dB over sea-state-2 noise at 20 kHz (Everest et al. 1948), sea state 2 ~ 4 m/s."""
    sea_state_2 = 50 + 7.5 * 2.0 + 20 * math.log10(20.0) - 40 * math.log10(20.4)
    assert SHRIMP_BED_DB == pytest.approx(sea_state_2 + 25.0)
    reef = SeaState(shrimp_db=SHRIMP_BED_DB)
    assert noise_psd_db(25.0, reef) - noise_psd_db(25.0, OPEN_SEA) > 20.0


@pytest.mark.parametrize("bad", [{"wind_mps": -1.0}, {"wind_mps": math.inf},
                                 {"shipping": -0.1}, {"shipping": 1.1},
                                 {"shrimp_db": math.nan}, {"shrimp_db": math.inf}])
def test_sea_state_validates_itself(bad: dict) -> None:
    with pytest.raises(ValueError):
        SeaState(**bad)


def test_band_must_be_above_zero() -> None:
    with pytest.raises(ValueError):
        band_noise_db(2.0, 4.0, OPEN_SEA)


# -- modulation -------------------------------------------------------------------------------

def test_bit_error_rates_against_textbook_points() -> None:
    # BPSK needs 9.6 dB for 1e-5; non-coherent BFSK 13.35 dB (0.5 exp(-21.63 / 2) = 1e-5)
    assert Modulation.parse("bpsk").bit_error_rate(10 ** 0.96) == pytest.approx(1.0e-5, rel=0.03)
    assert Modulation.parse("qpsk").bit_error_rate(10 ** 0.96) == pytest.approx(1.0e-5, rel=0.03)
    assert Modulation.parse("bfsk").bit_error_rate(10 ** 1.335) == pytest.approx(1.0e-5, rel=0.03)
    # Q(x) = 0.5 erfc(x / sqrt 2): Q(0) = 1/2, Q(1.959964) = 0.025
    assert q_function(0.0) == 0.5 and q_function(1.959964) == pytest.approx(0.025, rel=1e-6)


@pytest.mark.parametrize("ebn0", [0.5, 2.0, 5.0, 12.0])
def test_m_ary_error_rates(ebn0: float) -> None:
    # 4-FSK: P_s = 3/2 e^{-g} - e^{-4g/3} + 1/4 e^{-3g/2} with g = 2 Eb/N0 / 2; BER = 2/3 P_s
    g = 2 * ebn0
    ps = 1.5 * math.exp(-g / 2) - math.exp(-2 * g / 3) + 0.25 * math.exp(-3 * g / 4)
    assert Modulation.parse("4fsk").bit_error_rate(ebn0) == pytest.approx(min(0.5, ps * 2 / 3))
    # 8-PSK (Gray): (2/3) Q(sqrt(6 Eb/N0) sin(pi/8))
    x = math.sqrt(6 * ebn0) * math.sin(math.pi / 8)
    eight = 2 / 3 * 0.5 * math.erfc(x / math.sqrt(2))
    assert Modulation.parse("8psk").bit_error_rate(ebn0) == pytest.approx(min(0.5, eight))


def test_frame_success_and_names() -> None:
    assert frame_success(1e-3, 512) == pytest.approx(0.999 ** 512)
    assert frame_success(1.0, 8) == 0.0 and frame_success(0.0, 8) == 1.0
    assert Modulation.parse("16fsk") == Modulation("fsk", 16)
    for bad in ("ofdm", "3psk", "psk"):
        with pytest.raises(ValueError):
            Modulation.parse(bad)


def test_error_table_interpolates_and_clamps() -> None:
    t = MICROMODEM_RATE1_TABLE
    # between (-7.234, 0.727) and (-6.845, 0.170): 0.727 - (0.234 / 0.389) * 0.557
    assert t.frame_error_at(-7.0) == pytest.approx(0.727 - 0.234 / 0.389 * 0.557)
    assert t.frame_error_at(-20.0) == 1.0 and t.frame_error_at(10.0) == 0.0
    assert t.success(-7.0, 64) == pytest.approx(1 - t.frame_error_at(-7.0))
    assert t.success(-7.0, 65) == pytest.approx((1 - t.frame_error_at(-7.0)) ** 2)  # 2 frames
    with pytest.raises(ValueError):
        ErrorTable((0.0, 1.0), (0.0, 1.0), 64)  # error growing with SNR


def test_eb_n0_is_snr_plus_processing_gain() -> None:
    m = Modem("m", 25.0, 5.0, 185.0, "bpsk", coding_gain_db=2.0)
    assert m.ebn0_db(3.0, 1000.0) == pytest.approx(3.0 + 10 * math.log10(5.0) + 2.0)
    ebn0 = 10 ** (m.ebn0_db(-1.0, 500.0) / 10)
    expected = (1 - 0.5 * math.erfc(math.sqrt(2 * ebn0) / math.sqrt(2))) ** (8 * 32)
    assert m.success(-1.0, 32, 500.0) == pytest.approx(expected)


@pytest.mark.parametrize("bad", [
    {"frequency_khz": 0.5}, {"bandwidth_khz": 60.0}, {"source_level_db": math.nan},
    {"modulation": "ofdm"}, {"modulation": "table"},
    {"error_table": MICROMODEM_RATE1_TABLE},  # a table needs modulation="table"
])
def test_modem_validates_itself(bad: dict) -> None:
    with pytest.raises(ValueError):
        replace(MODEMS["psk_1k"], **bad)


# -- fading -----------------------------------------------------------------------------------

def test_sampled_gains_have_the_rician_moments() -> None:
    u = np.random.default_rng(3).random((40_000, 2))
    for k in (0.0, 5.0):
        x = np.array([power_gain(a, b, k) for a, b in u])
        assert x.mean() == pytest.approx(1.0, abs=0.02)
        # power variance of Rician fading: (1 + 2K) / (1 + K)^2
        assert x.var() == pytest.approx((1 + 2 * k) / (1 + k) ** 2, rel=0.05)
    rayleigh = np.array([power_gain(a, b, 0.0) for a, b in u])
    assert (rayleigh < 0.1).mean() == pytest.approx(1 - math.exp(-0.1), abs=0.005)
    assert power_gain(0.3, 0.7, None) == 1.0


@pytest.mark.parametrize("mean_db", [-5.0, 0.0, 10.0, 25.0])
def test_fading_average_matches_closed_forms(mean_db: float) -> None:
    """Rayleigh averages (Proakis 14.3): BFSK 1/(2 + g), BPSK (1 - sqrt(g/(1+g)))/2."""
    g = 10 ** (mean_db / 10)
    bfsk = mean_success(lambda s: 1 - 0.5 * math.exp(-10 ** (s / 10) / 2), mean_db, 0.0)
    assert 1 - bfsk == pytest.approx(1 / (2 + g), rel=1e-3)
    bpsk = mean_success(lambda s: 1 - q_function(math.sqrt(2 * 10 ** (s / 10))), mean_db, 0.0)
    assert 1 - bpsk == pytest.approx(0.5 * (1 - math.sqrt(g / (1 + g))), rel=1e-3)
    # a step is the quadrature's worst case (it may split a grid cell of 0.065 dB)
    step = mean_success(lambda s: float(s >= 0.0), mean_db, 0.0)  # P(x >= 1/g) = e^{-1/g}
    assert step == pytest.approx(math.exp(-1 / g), abs=5e-3)


# -- the sonar equation -----------------------------------------------------------------------

def test_snr_is_source_minus_loss_minus_noise() -> None:
    b = LinkBudget(MODEMS["psk_1k"], OPEN_SEA, rician_k=None)
    for r in (100.0, 750.0, 2500.0):
        tl = 15 * math.log10(r) + 6.104805 * r / 1000
        assert b.snr_db(r) == pytest.approx(185.0 - tl - b.noise_db, abs=1e-5)
    # SNR differences between ranges are TL differences
    assert b.snr_db(300.0) - b.snr_db(3000.0) == pytest.approx(
        15 * math.log10(10.0) + 6.104805 * 2.7, abs=1e-5)


def test_louder_sources_and_quieter_seas_reach_further() -> None:
    base = LinkBudget(MODEMS["psk_1k"], SeaState(shrimp_db=SHRIMP_BED_DB), rician_k=0.0)
    r = 2000.0
    p = base.delivery_probability(r)
    assert replace(base, modem=replace(base.modem, source_level_db=191.0)) \
        .delivery_probability(r) > p
    assert LinkBudget(base.modem, OPEN_SEA, rician_k=0.0).delivery_probability(r) > p
    assert LinkBudget(base.modem, replace(base.sea, wind_mps=20.0, shrimp_db=-math.inf),
                      rician_k=0.0).delivery_probability(r) > p  # shrimp louder than wind
    assert replace(base, bitrate_bps=5000.0).delivery_probability(r) < p  # less energy per bit
    higher = replace(base, modem=replace(base.modem, frequency_khz=60.0))
    assert higher.delivery_probability(r) < p  # absorption grows faster than noise falls


def test_hearing_range_is_where_frames_stop_mattering() -> None:
    b = LinkBudget(MODEMS["psk_1k"], SeaState(shrimp_db=SHRIMP_BED_DB), rician_k=0.0)
    horizon = b.hearing_range_m()
    assert b.delivery_probability(horizon) < 1e-9
    # interference there is 10 dB under the decoder's noise floor (or frames decode further)
    assert b.received_level_db(horizon) <= b.decoder_noise_db + HEARING_SNR_DB + 1e-6
