"""Cost per frame of the Micro-Modem NMEA path: the project's driver -> TCP -> emulated
modem -> channel -> emulated modem -> TCP -> driver, all in this process (so process CPU
time covers both drivers, both sockets' ends, the water and its scheduler).

    python -m benchmarks.modem_bench [--packets N] [--warp W]

Prints CPU microseconds per frame delivered (3 frames of 64 bytes per packet, rate 1) and
the wall time per packet. Compare `benchmarks/relay_bench.py` (relay CPU per tx frame).
"""

from __future__ import annotations

import argparse
import socket
import threading
import time

from comms_sim.micromodem.run import run_water
from fleet_agent.modems.micromodem import MicroModem
from fleet_bus.modem_port import Received, Sent


def free_base_port(n: int) -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main(packets: int, warp: float) -> dict[str, float]:
    """Send ``packets`` full rate-1 packets from one driver to the other; the figures."""
    stop, box = threading.Event(), {}
    port = free_base_port(2)
    water = threading.Thread(target=run_water, args=(
        [("a", (0.0, 0.0, -5.0)), ("b", (300.0, 0.0, -5.0))], "127.0.0.1", port, 1, warp, 0,
        stop), kwargs={"on_ready": lambda s, f: box.update(fleet=f), "heartbeat_s": 0.0})
    water.start()
    while "fleet" not in box:
        time.sleep(0.01)
    clock = box["fleet"].water.clock
    sent, got = threading.Semaphore(0), []
    a = MicroModem(f"tcp:127.0.0.1:{port}", lambda r: isinstance(r, Sent) and sent.release(),
                   clock)
    b = MicroModem(f"tcp:127.0.0.1:{port + 1}",
                   lambda r: isinstance(r, Received) and got.append(r), clock)
    while not (a.connected and b.connected):
        time.sleep(0.01)
    frames = [bytes([i]) * 64 for i in range(3)]
    cpu0, wall0 = time.process_time(), time.perf_counter()
    for _ in range(packets):
        a.transmit(frames, "data")
        sent.acquire(timeout=30)
    deadline = time.monotonic() + 30
    while len(got) < 3 * packets and time.monotonic() < deadline:
        time.sleep(0.001)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    a.close()
    b.close()
    stop.set()
    water.join()
    per_frame_us = 1e6 * cpu / max(1, len(got))
    print(f"{packets} packets, {len(got)} frames delivered at warp {warp:g}: "
          f"{per_frame_us:.0f} us CPU per frame (both drivers, sockets, "
          f"water), {1e3 * wall / packets:.1f} ms wall per packet")
    return {"packets": packets, "frames": len(got), "cpu_us_per_frame": per_frame_us,
            "wall_ms_per_packet": 1e3 * wall / packets}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--packets", type=int, default=200)
    parser.add_argument("--warp", type=float, default=1000.0)
    args = parser.parse_args()
    main(args.packets, args.warp)
