"""Parameters of the acoustic channel: the modem, the water, and the faults to inject.

Defaults imitate a phase-coherent (PSK) acoustic modem at about 1 kbps burst rate, in the
class of the WHOI Micro-Modem's low PSK rates, with EvoLogics-style 64-byte instant messages;
the preamble (probe + guard) of a Micro-Modem PSK packet lasts about 0.3 s. Named presets
(`PRESETS`) keep slower modems available, among them Micro-Modem rate 0 (FH-FSK, one 32-byte
frame at 80 bps) and the range curve of the LSTS DUNE simulator.

Range curve: a frame sent over ``d`` metres is decodable with probability
``2 ** -((d / range_d50_m) ** range_shape)`` (1 at zero range, 1/2 at ``range_d50_m``) and never
beyond ``max_range_m``. DUNE's ``exp(-d^2 / (2 * 750^2))`` is ``range_shape=2``,
``range_d50_m=750 * sqrt(2 ln 2) = 883 m``. The default (d50 = 2 km, shape 4) keeps a
1-1.5 km reef fleet workable: about 96 % at 1 km, 80 % at 1.5 km, 3 % at 3 km.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Iterable, Mapping

from fleet_bus.link import Partition


@dataclass(frozen=True)
class TdmaConfig:
    """Fixed time slots, one per vehicle, repeating every ``slot_s * n_slots`` seconds.

    ``order`` fixes the slot of each listed vehicle; unlisted vehicles get the following slots
    in the order they first transmit (which lengthens the cycle for everyone, so list them all
    when the fleet is known). A frame starts only if it ends ``guard_s`` before its slot does,
    so that it has reached every receiver within range before the next slot opens.
    """

    slot_s: float = 3.0
    order: tuple[str, ...] = ()
    guard_s: float = 2.0  # 3 km at 1500 m/s

    def __post_init__(self) -> None:
        object.__setattr__(self, "order", tuple(str(n) for n in self.order))
        if not self.slot_s > 0 or not self.guard_s >= 0:
            raise ValueError(f"need slot_s > 0 and guard_s >= 0, got {self.slot_s}, {self.guard_s}")
        if len(set(self.order)) != len(self.order):
            raise ValueError(f"TDMA order lists a vehicle twice: {self.order}")


@dataclass(frozen=True)
class ChannelConfig:
    """One acoustic channel shared by the whole fleet (a broadcast medium)."""

    sound_speed_mps: float = 1500.0
    bitrate_bps: float = 1000.0  # burst rate of the payload
    preamble_s: float = 0.3  # detection probe + header, sent before every frame
    max_frame_bytes: int = 64
    range_d50_m: float = 2000.0  # range at which half the frames are lost
    range_shape: float = 4.0  # steepness of the loss curve (2 = Gaussian, as in DUNE)
    max_range_m: float = 3000.0  # nothing is heard beyond: no decoding, no interference
    extra_loss: float = 0.0  # uniform loss on top, for fault injection
    partitions: tuple[Partition, ...] = ()
    half_duplex: bool = True
    collisions: bool = True
    tdma: TdmaConfig | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "partitions", tuple(self.partitions))
        positive = ("sound_speed_mps", "bitrate_bps", "range_d50_m", "range_shape", "max_range_m")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if not self.preamble_s >= 0:
            raise ValueError(f"preamble_s must be >= 0, got {self.preamble_s}")
        if not (isinstance(self.max_frame_bytes, int) and self.max_frame_bytes > 0):
            raise ValueError(f"max_frame_bytes must be a positive int, got {self.max_frame_bytes}")
        if not 0.0 <= self.extra_loss <= 1.0:
            raise ValueError(f"extra_loss must be in [0, 1], got {self.extra_loss}")
        if not all(isinstance(p, Partition) for p in self.partitions):
            raise ValueError("partitions must be Partition instances")
        if self.tdma is not None:
            longest = self.airtime_s(self.max_frame_bytes) + self.tdma.guard_s
            if self.tdma.slot_s < longest:
                raise ValueError(
                    f"TDMA slot {self.tdma.slot_s} s cannot hold a {self.max_frame_bytes}-byte "
                    f"frame plus guard ({longest:.3f} s)")

    def airtime_s(self, nbytes: int) -> float:
        """How long the transmitter is busy with a frame of ``nbytes``."""
        return self.preamble_s + 8.0 * nbytes / self.bitrate_bps

    def delay_s(self, range_m: float) -> float:
        return range_m / self.sound_speed_mps

    def delivery_probability(self, range_m: float) -> float:
        """Chance that a frame sent over ``range_m`` is decodable (before extra loss)."""
        if range_m > self.max_range_m:
            return 0.0
        return 2.0 ** -((range_m / self.range_d50_m) ** self.range_shape)


# Named modems. Rates are burst rates of the payload; preambles are approximate.
PRESETS: dict[str, ChannelConfig] = {
    # The default: PSK at ~1 kbps (Micro-Modem PSK class), 64-byte frames.
    "psk_1k": ChannelConfig(),
    # A slower, more robust PSK rate.
    "psk_500": ChannelConfig(bitrate_bps=500.0),
    # Micro-Modem high PSK rate (~5 kbps), still with 64-byte messages.
    "psk_5k": ChannelConfig(bitrate_bps=5000.0),
    # WHOI Micro-Modem rate 0: FH-FSK, one 32-byte frame at 80 bps (3.2 s of payload).
    "micromodem_rate0": ChannelConfig(bitrate_bps=80.0, preamble_s=0.5, max_frame_bytes=32),
    # The default modem under the LSTS DUNE simulator's range curve (sigma 750 m, 3 km cut).
    "dune_sim": ChannelConfig(range_d50_m=750.0 * math.sqrt(2.0 * math.log(2.0)),
                              range_shape=2.0),
}


def with_tdma(config: ChannelConfig, order: Iterable[str],
              guard_s: float | None = None) -> ChannelConfig:
    """``config`` with one TDMA slot per vehicle of ``order``: just long enough for the largest
    frame plus a guard (default: the propagation time over ``max_range_m``), rounded up to
    0.1 s. Pure ALOHA stops carrying a fleet's gossip beyond a handful of vehicles; this is
    the MAC real acoustic fleets use."""
    guard = config.max_range_m / config.sound_speed_mps if guard_s is None else guard_s
    slot = math.ceil((config.airtime_s(config.max_frame_bytes) + guard) * 10.0 - 1e-9) / 10.0
    return replace(config, tdma=TdmaConfig(slot_s=slot, order=tuple(order), guard_s=guard))


def config_from_dict(doc: Mapping[str, Any]) -> ChannelConfig:
    """Build a config from a plain document (TOML/JSON/msgpack): ``preset`` names the base,
    every other key overrides a `ChannelConfig` field; ``tdma`` is a table of `TdmaConfig`
    fields, ``partitions`` a list of `Partition.from_dict` tables. Raises ValueError."""
    doc = dict(doc)
    name = doc.pop("preset", "psk_1k")
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; known: {sorted(PRESETS)}")
    known = {f.name for f in fields(ChannelConfig)}
    unknown = set(doc) - known
    if unknown:
        raise ValueError(f"unknown channel settings: {sorted(unknown)}")
    try:
        if doc.get("tdma") is not None:
            tdma = dict(doc["tdma"])
            tdma["order"] = tuple(tdma.get("order", ()))
            doc["tdma"] = TdmaConfig(**tdma)
        doc["partitions"] = tuple(Partition.from_dict(p) for p in doc.get("partitions", ()))
        return replace(PRESETS[name], **doc)
    except TypeError as exc:
        raise ValueError(f"bad channel settings: {exc}") from None


def load_config(path: str | Path) -> ChannelConfig:
    """Read a ``.toml`` or ``.json`` channel file (see `config_from_dict`)."""
    path = Path(path)
    if path.suffix == ".toml":
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    elif path.suffix == ".json":
        doc = json.loads(path.read_text(encoding="utf-8"))
    else:
        raise ValueError(f"channel config must be .toml or .json, got {path.name}")
    return config_from_dict(doc)

