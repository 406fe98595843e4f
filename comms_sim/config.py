"""Parameters of the acoustic channel: the modem, the water, and the faults to inject.

Two models decide whether a frame arrives (``model``):

- ``"physical"`` (default): the sonar equation. A frame sent over ``d`` metres arrives at the
  mean level SL - TL(d) (practical spreading plus Thorp's absorption at the modem's carrier,
  `comms_sim.acoustics.propagation`) against the ambient noise of the water in the modem's
  band (`comms_sim.acoustics.noise`: wind, shipping, thermal, turbulence, snapping shrimp),
  fades (Rician, ``rician_k``; 0 is Rayleigh, the default 5), and decodes with the modem's
  error rate at its SINR (`comms_sim.acoustics.modems`). The modem's physical layer is
  ``modem``; the water is ``wind_mps``, ``shipping``, ``shrimp_db``, ``spreading_k``,
  ``absorption_db_per_km``, ``rician_k``.
- ``"empirical"``: the project's earlier range curve, ``2 ** -((d / range_d50_m) **
  range_shape)``, the same for every modem, nothing heard beyond ``max_range_m``, and two
  overlapping frames always both lost. DUNE's ``exp(-d^2 / (2 * 750^2))`` is
  ``range_shape=2``, ``range_d50_m=750 * sqrt(2 ln 2) = 883 m``. Kept so that the new channel
  can be compared with the old (`PRESETS` "empirical_psk_1k", "dune_sim").

The link layer (bit rate, preamble, largest frame) is the same for both: it sets a frame's
airtime, which the MAC (TDMA) uses too. The default imitates a ~1 kbps PSK modem in the class
of the WHOI Micro-Modem's low PSK rates, with EvoLogics-style 64-byte instant messages and the
~0.3 s probe and gap of a Micro-Modem PSK packet, on a coral reef: delivery of a 64-byte frame
99 % at 1 km, 93 % at 1.5 km, 50 % at 2 km (the earlier empirical curve's d50), 2.5 % at 2.5 km.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, fields, replace
from pathlib import Path
from functools import cached_property
from typing import Any, Iterable, Mapping

from comms_sim.acoustics.budget import LinkBudget
from comms_sim.acoustics.modems import MODEMS, Modem
from comms_sim.acoustics.modulation import ErrorTable
from comms_sim.acoustics.noise import SHRIMP_BED_DB, SeaState
from fleet_bus.link import Partition

MODELS = ("physical", "empirical")
EMPIRICAL_MAX_RANGE_M = 3000.0  # the empirical model's hard cut when max_range_m is unset


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
    """One acoustic channel shared by the whole fleet (a broadcast medium). See the module
    docstring for the two models; fields are grouped by what they describe."""

    sound_speed_mps: float = 1500.0
    # link layer: a frame's airtime is preamble_s + 8 * bytes / bitrate_bps
    bitrate_bps: float = 1000.0  # burst rate of the payload
    preamble_s: float = 0.3  # detection probe + header, sent before every frame
    max_frame_bytes: int = 64
    model: str = "physical"
    # physical model: the modem's physical layer and the water
    modem: Modem = MODEMS["psk_1k"]
    wind_mps: float = 5.0  # ~10 knots
    shipping: float = 0.5  # distant shipping activity, 0..1 (Stojanovic)
    shrimp_db: float = SHRIMP_BED_DB  # snapping shrimp, dB re 1 uPa^2/Hz; -inf: open water
    spreading_k: float = 1.5  # practical spreading
    absorption_db_per_km: float | None = None  # None: Thorp at the modem's carrier
    # Fading: Rician factor, the steady path's power over the scattered paths' (0 Rayleigh,
    # None no fading). 5: a direct path 7 dB above the multipath, a short line-of-sight link
    # between vehicles at similar depths.
    rician_k: float | None = 5.0
    # empirical model: the range curve
    range_d50_m: float = 2000.0  # range at which half the frames are lost
    range_shape: float = 4.0  # steepness of the loss curve (2 = Gaussian, as in DUNE)
    # Nothing is heard beyond: no decoding, no interference. None: the physical model's
    # hearing range (`LinkBudget.hearing_range_m`), or 3000 m for the empirical model.
    max_range_m: float | None = None
    # both models
    extra_loss: float = 0.0  # uniform loss on top, for fault injection
    partitions: tuple[Partition, ...] = ()
    half_duplex: bool = True
    collisions: bool = True  # physical: interference counts in the SINR; empirical: overlaps
    tdma: TdmaConfig | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "partitions", tuple(self.partitions))
        positive = ("sound_speed_mps", "bitrate_bps", "range_d50_m", "range_shape")
        for name in positive:
            _check_positive(name, getattr(self, name))
        if self.max_range_m is not None:
            _check_positive("max_range_m", self.max_range_m)
        if not self.preamble_s >= 0:
            raise ValueError(f"preamble_s must be >= 0, got {self.preamble_s}")
        if not (isinstance(self.max_frame_bytes, int) and self.max_frame_bytes > 0):
            raise ValueError(f"max_frame_bytes must be a positive int, got {self.max_frame_bytes}")
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")
        if not isinstance(self.modem, Modem):
            raise ValueError(f"modem must be a Modem, got {self.modem!r}")
        if not 0.0 <= self.extra_loss <= 1.0:
            raise ValueError(f"extra_loss must be in [0, 1], got {self.extra_loss}")
        if not all(isinstance(p, Partition) for p in self.partitions):
            raise ValueError("partitions must be Partition instances")
        # The water and the link budget validate themselves (and fail here, not mid-run).
        SeaState(self.wind_mps, self.shipping, self.shrimp_db)
        if self.model == "physical":
            self.budget  # computes (and caches) the budget, raising if invalid
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

    @property
    def sea(self) -> SeaState:
        return SeaState(self.wind_mps, self.shipping, self.shrimp_db)

    @cached_property
    def budget(self) -> LinkBudget:
        """The physical model's sonar equation for this modem in this water."""
        return LinkBudget(self.modem, self.sea, self.spreading_k, self.absorption_db_per_km,
                          self.bitrate_bps, self.rician_k)

    @cached_property
    def horizon_m(self) -> float:
        """Beyond this range nothing is heard: ``max_range_m`` if set, else the physical
        hearing range for the largest frame (the empirical model: 3000 m)."""
        if self.max_range_m is not None:
            return float(self.max_range_m)
        if self.model == "empirical":
            return EMPIRICAL_MAX_RANGE_M
        return self.budget.hearing_range_m(self.max_frame_bytes)

    def delivery_probability(self, range_m: float, nbytes: int | None = None) -> float:
        """Chance that a lone frame of ``nbytes`` (default: the largest) sent over
        ``range_m`` decodes, before extra loss (physical: expected over fading)."""
        if range_m > self.horizon_m:
            return 0.0
        if self.model == "empirical":
            return 2.0 ** -((range_m / self.range_d50_m) ** self.range_shape)
        return self.budget.delivery_probability(
            range_m, self.max_frame_bytes if nbytes is None else nbytes)


def _check_positive(name: str, value: object) -> None:
    if not (isinstance(value, (int, float)) and value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")


# Named channels: a modem's physical layer with its link layer. Where each number comes from:
# `comms_sim.acoustics.modems` and docs/comms_sim.md.
PRESETS: dict[str, ChannelConfig] = {
    # The default: BPSK at 1 kbps in the Micro-Modem's PSK band, 64-byte frames, on a reef.
    "psk_1k": ChannelConfig(),
    # The same modem at other rates: Eb/N0 moves by 10 log10 of the rate ratio.
    "psk_500": ChannelConfig(bitrate_bps=500.0),
    "psk_5k": ChannelConfig(bitrate_bps=5000.0),
    # WHOI Micro-Modem rate 0: FH-FSK, one 32-byte frame at 80 bps (3.2 s of payload).
    "micromodem_rate0": ChannelConfig(bitrate_bps=80.0, preamble_s=0.5, max_frame_bytes=32,
                                      modem=MODEMS["micromodem_rate0"]),
    # Micro-Modem PSK rate 1 (64-byte frames; ~500 bps burst, assumed) and rate 5 (256-byte
    # frames, ~5000 bps burst), decoded through ros_acomms' SNR tables.
    "micromodem_psk1": ChannelConfig(bitrate_bps=500.0, modem=MODEMS["micromodem_psk1"]),
    "micromodem_psk5": ChannelConfig(bitrate_bps=5000.0, max_frame_bytes=256,
                                     modem=MODEMS["micromodem_psk5"]),
    # EvoLogics S2C R 18/34: 13.9 kbit/s, 64-byte instant messages (preamble assumed 0.3 s).
    "evologics_s2c_18_34": ChannelConfig(bitrate_bps=13900.0,
                                         modem=MODEMS["evologics_s2c_18_34"]),
    # The project's earlier channel: the empirical curve (d50 2 km, shape 4, 3 km cut) with
    # the default link layer, and the LSTS DUNE simulator's curve (sigma 750 m, 3 km cut).
    "empirical_psk_1k": ChannelConfig(model="empirical", max_range_m=3000.0),
    "dune_sim": ChannelConfig(model="empirical", max_range_m=3000.0,
                              range_d50_m=750.0 * math.sqrt(2.0 * math.log(2.0)),
                              range_shape=2.0),
}


def with_tdma(config: ChannelConfig, order: Iterable[str],
              guard_s: float | None = None) -> ChannelConfig:
    """``config`` with one TDMA slot per vehicle of ``order``: just long enough for the largest
    frame plus a guard (default: the propagation time over the range anything is heard,
    `ChannelConfig.horizon_m`), rounded up to 0.1 s. Pure ALOHA stops carrying a fleet's
    gossip beyond a handful of vehicles; this is the MAC real acoustic fleets use."""
    guard = config.horizon_m / config.sound_speed_mps if guard_s is None else guard_s
    slot = math.ceil((config.airtime_s(config.max_frame_bytes) + guard) * 10.0 - 1e-9) / 10.0
    return replace(config, tdma=TdmaConfig(slot_s=slot, order=tuple(order), guard_s=guard))


def config_from_dict(doc: Mapping[str, Any]) -> ChannelConfig:
    """Build a config from a plain document (TOML/JSON/msgpack): ``preset`` names the base,
    every other key overrides a `ChannelConfig` field; ``modem`` is the name of a modem
    (`comms_sim.acoustics.modems.MODEMS`) or a table of `Modem` fields overriding the
    preset's (``error_table`` a table of ``snr_db``, ``frame_error``, ``frame_bytes``);
    ``tdma`` is a table of `TdmaConfig` fields, ``partitions`` a list of `Partition.from_dict`
    tables. Sea state: ``wind_mps``, ``shipping``, ``shrimp_db``. Raises ValueError."""
    doc = dict(doc)
    name = doc.pop("preset", "psk_1k")
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; known: {sorted(PRESETS)}")
    base = PRESETS[name]
    known = {f.name for f in fields(ChannelConfig)}
    unknown = set(doc) - known
    if unknown:
        raise ValueError(f"unknown channel settings: {sorted(unknown)}")
    try:
        if doc.get("tdma") is not None:
            tdma = dict(doc["tdma"])
            tdma["order"] = tuple(tdma.get("order", ()))
            doc["tdma"] = TdmaConfig(**tdma)
        if "modem" in doc:
            doc["modem"] = _modem_from(doc["modem"], base.modem)
        doc["partitions"] = tuple(Partition.from_dict(p) for p in doc.get("partitions", ()))
        return replace(base, **doc)
    except TypeError as exc:
        raise ValueError(f"bad channel settings: {exc}") from None


def _modem_from(value: Any, base: Modem) -> Modem:
    if isinstance(value, str):
        if value not in MODEMS:
            raise ValueError(f"unknown modem {value!r}; known: {sorted(MODEMS)}")
        return MODEMS[value]
    if not isinstance(value, Mapping):
        raise ValueError(f"modem must be a name or a table, got {value!r}")
    changes = dict(value)
    if "error_table" in changes:
        t = changes["error_table"]
        changes["error_table"] = ErrorTable(tuple(t["snr_db"]), tuple(t["frame_error"]),
                                            int(t["frame_bytes"]))
        changes.setdefault("modulation", "table")
    return replace(base, **changes)


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

