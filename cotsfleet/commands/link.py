"""`cotsfleet link`: the acoustic link budget of a modem, at one range or as a table (and plot)
of delivery against range.

For a frame of ``--bytes`` (64 by default, or the modem's largest if smaller): the carrier
frequency, transmission loss (practical spreading plus Thorp absorption), band noise of the
water, mean SNR (SL - TL - NL), the SNR the decoder works with (less the modem's
implementation loss) and the chance the frame arrives (expected over fading, no
interference). See `comms_sim.acoustics` and docs/comms_sim.md for the physics and sources.
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

from comms_sim.acoustics.budget import crossing_range_m
from comms_sim.config import PRESETS, ChannelConfig, load_config
from cotsfleet.commands.checks import output_file
from cotsfleet.errors import UsageError

HELP = "acoustic link budget of a modem: SNR and delivery at a range, or against range"

TABLE_RANGES_M = (100, 250, 500, 750, 1000, 1250, 1500, 1750, 2000, 2500, 3000, 3500, 4000,
                  5000, 6000, 8000, 10000, 12000, 15000, 20000)
LEVELS = (0.9, 0.5, 0.1)  # the summary line: where delivery falls to 90, 50 and 10 %


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--modem", default="psk_1k", metavar="NAME",
                        help=f"channel preset (default psk_1k): {', '.join(PRESETS)}")
    source.add_argument("--config", type=Path, metavar="CHANNEL.toml|json",
                        help="a channel settings file instead of a preset")
    parser.add_argument("--range", type=float, metavar="M", dest="range_m",
                        help="one range in metres; without it, a table against range")
    parser.add_argument("--bytes", type=int, metavar="N",
                        help="frame size (default 64, or the modem's largest frame if smaller)")
    parser.add_argument("--wind", type=float, metavar="MPS", help="wind speed, m/s")
    parser.add_argument("--shipping", type=float, metavar="S", help="shipping activity, 0..1")
    parser.add_argument("--shrimp", metavar="DB|none",
                        help="snapping-shrimp noise, dB re 1 uPa^2/Hz, or 'none' (open water)")
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument("--plot", type=Path, metavar="FILE.png",
                        help="also draw delivery against range (needs matplotlib; no --range)")


def channel_from_args(args: argparse.Namespace) -> ChannelConfig:
    """The channel the flags describe (raises `UsageError`)."""
    if args.config is not None:
        try:
            config = load_config(args.config)
        except (OSError, ValueError) as exc:
            raise UsageError(f"cannot use {args.config}: {exc}") from None
    elif args.modem in PRESETS:
        config = PRESETS[args.modem]
    else:
        raise UsageError(f"unknown modem {args.modem!r}; choose from {', '.join(PRESETS)}")
    sea: dict[str, Any] = {}
    if args.wind is not None:
        sea["wind_mps"] = _finite("--wind", args.wind)
    if args.shipping is not None:
        sea["shipping"] = _finite("--shipping", args.shipping)
    if args.shrimp is not None:
        sea["shrimp_db"] = -math.inf if args.shrimp.lower() == "none" else _number(
            "--shrimp", args.shrimp)
    try:
        return replace(config, **sea)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _number(flag: str, text: str) -> float:
    try:
        return _finite(flag, float(text))
    except ValueError:
        raise UsageError(f"{flag} must be a number or 'none', got {text!r}") from None


def _finite(flag: str, value: float) -> float:
    if not math.isfinite(value):
        raise UsageError(f"{flag} must be finite, got {value}")
    return value


def frame_bytes(args: argparse.Namespace, config: ChannelConfig) -> int:
    if args.bytes is None:
        return min(64, config.max_frame_bytes)
    if not 1 <= args.bytes <= config.max_frame_bytes:
        raise UsageError(f"--bytes must be 1..{config.max_frame_bytes} for this modem, "
                         f"got {args.bytes}")
    return args.bytes


def budget_at(config: ChannelConfig, range_m: float, nbytes: int) -> dict[str, Any]:
    """The link budget of one frame of ``nbytes`` at ``range_m`` (physics figures for any
    model; delivery from the channel's model)."""
    b = config.budget
    snr = b.snr_db(range_m)
    return {"range_m": range_m, "nbytes": nbytes,
            "frequency_khz": config.modem.frequency_khz,
            "transmission_loss_db": round(b.transmission_loss_db(range_m), 2),
            "noise_db": round(b.noise_db, 2),
            "snr_db": round(snr, 2),
            "decoder_snr_db": round(snr - config.modem.implementation_loss_db, 2),
            "delivery_probability": round(config.delivery_probability(range_m, nbytes), 4)}


def describe(name: str, config: ChannelConfig) -> dict[str, Any]:
    m = config.modem
    return {"modem": name, "model": config.model, "modulation": m.modulation,
            "frequency_khz": m.frequency_khz, "bandwidth_khz": m.bandwidth_khz,
            "source_level_db": m.source_level_db, "bitrate_bps": config.bitrate_bps,
            "implementation_loss_db": m.implementation_loss_db,
            "wind_mps": config.wind_mps, "shipping": config.shipping,
            "shrimp_db": None if config.shrimp_db == -math.inf else round(config.shrimp_db, 1),
            "rician_k": config.rician_k, "hearing_range_m": round(config.horizon_m)}


def summary_ranges(config: ChannelConfig, nbytes: int) -> dict[str, float]:
    """Where delivery falls to 90, 50 and 10 %."""
    limit = config.horizon_m
    return {f"range_{int(100 * p)}_m": round(crossing_range_m(
        lambda r: config.delivery_probability(r, nbytes), p, limit)) for p in LEVELS}


def run(args: argparse.Namespace) -> int:
    output_file(args.plot, "--plot")
    config = channel_from_args(args)
    name = str(args.config) if args.config is not None else args.modem
    nbytes = frame_bytes(args, config)
    if args.range_m is not None:
        if args.plot is not None:
            raise UsageError("--plot draws delivery against range: drop --range")
        if not (math.isfinite(args.range_m) and args.range_m >= 0):
            raise UsageError(f"--range must be a distance >= 0 in metres, got {args.range_m}")
        doc = {**describe(name, config), **budget_at(config, args.range_m, nbytes)}
        print(json.dumps(doc, indent=1) if args.json else _format_one(doc))
        return 0
    # up to the first range where nothing is heard any more
    shown = [r for r in TABLE_RANGES_M if r <= config.horizon_m]
    shown += [r for r in TABLE_RANGES_M if r > config.horizon_m][:1]
    rows = [budget_at(config, float(r), nbytes) for r in shown]
    summary = summary_ranges(config, nbytes)
    if args.plot is not None:
        plot(args.plot, name, config, nbytes)
    if args.json:
        print(json.dumps({**describe(name, config), "nbytes": nbytes, **summary,
                          "ranges": rows}, indent=1))
    else:
        print(_format_table(describe(name, config), nbytes, summary, rows))
    if args.plot is not None and not args.json:
        print(f"wrote {args.plot}")
    return 0


def _headline(d: dict[str, Any]) -> str:
    shrimp = "open water" if d["shrimp_db"] is None else f"shrimp {d['shrimp_db']:g} dB/Hz"
    return (f"{d['modem']} ({d['model']} model): {d['modulation']} at {d['bitrate_bps']:g} bps, "
            f"{d['frequency_khz']:g} kHz carrier, {d['bandwidth_khz']:g} kHz band, "
            f"{d['source_level_db']:g} dB re 1 uPa at 1 m; wind {d['wind_mps']:g} m/s, "
            f"shipping {d['shipping']:g}, {shrimp}, Rician K {d['rician_k']}")


def _format_one(doc: dict[str, Any]) -> str:
    keys = ("range_m", "nbytes", "frequency_khz", "transmission_loss_db", "noise_db", "snr_db",
            "implementation_loss_db", "decoder_snr_db", "delivery_probability")
    width = max(len(k) for k in keys)
    return "\n".join([_headline(doc)] + [f"{k:<{width}}  {doc[k]:g}" for k in keys])


def _format_table(d: dict[str, Any], nbytes: int, summary: dict[str, float],
                  rows: list[dict[str, Any]]) -> str:
    lines = [_headline(d), f"{nbytes}-byte frames; noise {rows[0]['noise_db']:g} dB re 1 uPa^2 "
             f"in band; implementation loss {d['implementation_loss_db']:g} dB; nothing heard "
             f"beyond {d['hearing_range_m']} m",
             f"delivery 90 % to {summary['range_90_m']:g} m, 50 % at "
             f"{summary['range_50_m']:g} m, 10 % at {summary['range_10_m']:g} m",
             f"{'range m':>8} {'TL dB':>7} {'SNR dB':>7} {'delivery':>9}"]
    for r in rows:
        lines.append(f"{r['range_m']:>8g} {r['transmission_loss_db']:>7.1f} {r['snr_db']:>7.1f} "
                     f"{r['delivery_probability']:>9.4f}")
    return "\n".join(lines)


def plot(path: Path, name: str, config: ChannelConfig, nbytes: int) -> None:
    """Delivery against range as a PNG (with the project's earlier empirical curve for
    reference when the modem is physical)."""
    try:
        import matplotlib

        matplotlib.use("Agg")  # files only: never a window
        import matplotlib.pyplot as plt
    except ImportError:
        raise UsageError("--plot needs matplotlib (pip install matplotlib)") from None
    import numpy as np

    top = max(1000.0, min(config.horizon_m, 20_000.0)) * 1.1
    ranges = np.linspace(0.0, top, 400)
    fig, ax = plt.subplots(figsize=(7.0, 4.0), dpi=120)
    ax.plot(ranges / 1000.0, [config.delivery_probability(r, nbytes) for r in ranges],
            label=f"{name} ({config.model})")
    if config.model == "physical":
        old = PRESETS["empirical_psk_1k"]
        ax.plot(ranges / 1000.0, [old.delivery_probability(r, nbytes) for r in ranges], "--",
                color="grey", label="empirical_psk_1k (earlier curve)")
    ax.set_xlabel("range (km)")
    ax.set_ylabel(f"delivery of a {nbytes}-byte frame")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(f"{name}: {config.modem.frequency_khz:g} kHz, {config.bitrate_bps:g} bps, "
                 f"wind {config.wind_mps:g} m/s")
    fig.tight_layout()
    try:
        fig.savefig(path, format="png")
    except OSError as exc:
        raise UsageError(f"cannot write {path}: {exc}") from None
    finally:
        plt.close(fig)
