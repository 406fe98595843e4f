"""Link faults at run time: a `fleet_bus.link.LinkControl` applied to the channel."""

from __future__ import annotations

from comms_sim.channel import Channel
from fleet_bus.link import LinkControl


def apply_control(control: LinkControl, channel: Channel, t_s: float | None = None) -> None:
    """Change ``channel`` for frames transmitted from ``t_s`` (default: its time) on, in the
    order clear partitions, add the partition, set the extra loss."""
    if control.clear_partitions:
        channel.clear_partitions(t_s)
    if control.partition is not None:
        channel.add_partition(control.partition, t_s)
    if control.extra_loss is not None:
        channel.set_extra_loss(control.extra_loss, t_s)
