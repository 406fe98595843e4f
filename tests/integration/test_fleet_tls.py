"""The "Across machines" procedure of docs/fleet_agent.md, run as written, over TLS.

Host A (the operator's) and host B (auv3's) are two network namespaces joined by a virtual
Ethernet link, with addresses of their own, so that host A's router listens off loopback
and the bus is TLS because of it (where namespaces cannot be made, two directories and two
routers on loopback, the ports told apart). The commands are read from the document's
``sh`` block and run by bash in each host's directory: ``cotsfleet`` and ``python`` are this
interpreter, ``scp ... HOST_B:`` copies to host B's directory, ``HOST_A`` is host A's
address. The launcher also gets ``--viewer none --warp 120 --run-dir run`` (no display, a
shorter mission, a known place for its report).

The link between the hosts is captured with tcpdump: every byte of it is inside a TLS
record, and nothing of the mission is in it in clear (run id, key expressions, vehicle ids,
message field names); the same search on a plain TCP link between two open routers finds
them, which shows the search would see them. Host B holds only auv3's and its router's
secrets. Every process is gone at the end.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from capture import Tcpdump, found, plaintext_markers, tcp_streams, tls_records
from fleet_bus.credentials import write_run_credentials
from fleet_bus.session import free_tcp_endpoint
from leftovers import alive

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "fleet_agent.md"
pytestmark = [pytest.mark.integration, pytest.mark.slow]
PORT = 7447  # the document's
TEST_FLAGS = " --viewer none --warp 120 --run-dir run"
LONG_RUNNING = ("cotsfleet run ", "python -m comms_sim.router ", "python -m fleet_agent ")

if shutil.which("tcpdump") is None:
    pytest.skip("tcpdump is not installed (apt-get install tcpdump): the capture of the link "
                "between the routers needs it", allow_module_level=True)
if os.geteuid() != 0:
    pytest.skip("capturing a link needs root (tcpdump)", allow_module_level=True)


def procedure() -> list[tuple[str, str]]:
    """(host, command) of the document's procedure, continuation lines joined."""
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("## Across machines"):]
    block = re.search(r"```sh\n(.*?)```", section, re.S)
    assert block, "no sh block in the Across machines section"
    steps, host = [], ""
    for line in block.group(1).replace("\\\n", " ").splitlines():
        head = re.match(r"# on host (\w)", line.strip())
        if head:
            host = head.group(1)
        elif line.strip() and not line.strip().startswith("#"):
            steps.append((host, " ".join(line.split())))
    return steps


@dataclass
class Host:
    prefix: list[str]  # runs a command on this host
    cwd: Path


@dataclass
class TwoHosts:
    a: Host
    b: Host
    address_a: str  # HOST_A: where host B dials host A
    iface: str  # the link between them, seen from host A
    port_a: int
    port_b: int
    namespaces: list[str] = field(default_factory=list)

    def render(self, host: str, command: str) -> str:
        """The document's command as this setup runs it on ``host``."""
        command = command.replace(f"HOST_A:{PORT}", f"{self.address_a}:{self.port_a}")
        command = command.replace("HOST_A", self.address_a)
        if not self.namespaces:  # one machine: nothing listens beyond loopback
            command = command.replace("0.0.0.0", "127.0.0.1")
        return command.replace(str(PORT), str(self.port_a if host == "A" else self.port_b))


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=20)


@pytest.fixture
def hosts(tmp_path: Path):
    a, b = tmp_path / "hostA", tmp_path / "hostB"
    a.mkdir()
    b.mkdir()
    tag = os.getpid() % 100000
    ns = [f"cfA{tag}", f"cfB{tag}"]
    subnet = f"10.231.{tag % 200 + 20}"
    try:
        for n in ns:
            _ip("netns", "add", n)
        _ip("link", "add", f"cfva{tag}", "netns", ns[0], "type", "veth", "peer", "name",
            f"cfvb{tag}", "netns", ns[1])
        _ip("-n", ns[0], "addr", "add", f"{subnet}.1/24", "dev", f"cfva{tag}")
        _ip("-n", ns[1], "addr", "add", f"{subnet}.2/24", "dev", f"cfvb{tag}")
        for n, dev in zip(ns, (f"cfva{tag}", f"cfvb{tag}")):
            _ip("-n", n, "link", "set", "lo", "up")
            _ip("-n", n, "link", "set", dev, "up")
        setup = TwoHosts(Host(["ip", "netns", "exec", ns[0]], a),
                         Host(["ip", "netns", "exec", ns[1]], b), f"{subnet}.1", f"cfva{tag}",
                         PORT, PORT, ns)
    except (subprocess.CalledProcessError, FileNotFoundError, subprocess.TimeoutExpired):
        for n in ns:
            subprocess.run(["ip", "netns", "del", n], capture_output=True)
        ports = [int(free_tcp_endpoint().rsplit(":", 1)[1]) for _ in range(2)]
        setup = TwoHosts(Host([], a), Host([], b), "127.0.0.1", "lo", *ports)
    try:
        yield setup
    finally:
        for n in setup.namespaces:
            subprocess.run(["ip", "netns", "del", n], capture_output=True)


def _tools(tmp_path: Path, host_b: Path) -> dict[str, str]:
    """The environment the document's commands run in: this interpreter as ``python`` and
    ``cotsfleet``, and an ``scp`` whose host B is a directory."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    scripts = {
        "python": 'exec "$TEST_PYTHON" "$@"\n',
        "cotsfleet": 'exec "$TEST_PYTHON" -m cotsfleet "$@"\n',
        "scp": ('files=(); for a in "$@"; do case "$a" in -*) ;; *) files+=("$a");; esac; done\n'
                'dest="${files[-1]}"; unset "files[-1]"\n'
                '[ "$dest" = "HOST_B:" ] || { echo "scp: not HOST_B: $dest" >&2; exit 2; }\n'
                'exec cp -rp "${files[@]}" "$HOST_B_DIR/"\n')}
    for name, body in scripts.items():
        (bin_dir / name).write_text("#!/bin/bash\n" + body)
        (bin_dir / name).chmod(0o755)
    return {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}",
            "TEST_PYTHON": sys.executable, "HOST_B_DIR": str(host_b),
            "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}


def _start(host: Host, command: str, env: dict[str, str], log: Path) -> subprocess.Popen:
    return subprocess.Popen([*host.prefix, "bash", "-c", "exec " + command], cwd=host.cwd,
                            env=env, stdout=log.open("w"), stderr=subprocess.STDOUT,
                            start_new_session=True)


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in procs:
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


def _files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()}


def test_the_documented_procedure_runs_over_tls_and_nothing_crosses_in_clear(
        hosts: TwoHosts, tmp_path: Path) -> None:
    steps = procedure()
    env = _tools(tmp_path, hosts.b.cwd)
    setup = [c for h, c in steps if h == "A" and not c.startswith(LONG_RUNNING)]
    later = [(h, c) for h, c in steps if c.startswith(LONG_RUNNING)]
    assert [c.split()[:3] for _, c in later] == [
        ["cotsfleet", "run", "--listen"], ["python", "-m", "comms_sim.router"],
        ["python", "-m", "fleet_agent"]]
    script = "set -e\n" + "\n".join(hosts.render("A", c) for c in setup)
    done = subprocess.run([*hosts.a.prefix, "bash", "-c", script], cwd=hosts.a.cwd, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr

    # Host B holds auv3's secrets and its router's, the fleet key, the scenario and the
    # mission file an agent on board runs from: nothing of another vehicle or of the
    # operator, no password.
    assert _files(hosts.b.cwd) == {
        "fleet.toml", "scenario.json", *(f"auv3/{f}" for f in (
            "ca.pem", "frames.key", "mission.json", "ring.json", "signing.key", "tls.key",
            "tls.pem")),
        *(f"router-auv3/{f}" for f in ("ca.pem", "ring.json", "tls.key", "tls.pem"))}
    for secret in ("auv3/signing.key", "auv3/frames.key", "auv3/tls.key", "router-auv3/tls.key",
                   "fleet.toml"):
        assert (hosts.b.cwd / secret).stat().st_mode & 0o077 == 0, secret
    run_id = json.loads((hosts.a.cwd / "creds" / "ring.json").read_text())["run_id"]

    capture = tmp_path / "link.pcap"
    dump = Tcpdump(hosts.a.prefix, hosts.iface, capture, f"tcp port {hosts.port_a}")
    procs: list[subprocess.Popen] = []
    pids: dict[str, list[int]] = {}
    try:
        for i, (host, command) in enumerate(later):
            line = hosts.render(host, command) + (TEST_FLAGS if i == 0 else "")
            procs.append(_start(hosts.a if host == "A" else hosts.b, line, env,
                                tmp_path / f"step{i}.log"))
        launcher, router_b, agent = procs
        assert launcher.wait(timeout=400) == 0, (tmp_path / "step0.log").read_text()[-3000:]
        assert agent.wait(timeout=30) == 0, "the launcher's stop command ends the remote agent"
        pids = json.loads((hosts.a.cwd / "run" / "pids.json").read_text())
    finally:
        _stop(procs)
        dump.stop()
    assert router_b.returncode in (0, -signal.SIGTERM)  # ended by us, cleanly

    report = json.loads((hosts.a.cwd / "run" / "report.json").read_text())
    vehicles = {v["id"]: v for v in report["vehicles"]}
    assert all(v["home"] for v in vehicles.values()), vehicles
    assert vehicles["auv3"]["tasks_treated"] > 0
    assert report["fleet"]["duplicate_treatments"] == 0
    assert report["messages"]["link_by_sender"]["auv3"]["delivered"] > 0

    # The link: TLS records only, carrying the mission, and nothing in clear.
    streams = tcp_streams(capture)
    assert streams, "nothing was captured on the link"
    for key, data in streams.items():
        kinds = tls_records(data)
        assert kinds[0] == 22, (key, "a TLS connection opens with a handshake")
    sent = sum(len(d) for d in streams.values())
    assert sent > 50_000, f"only {sent} bytes crossed the link"
    marks = plaintext_markers(run_id, ("auv1", "auv2", "auv3"))
    raw = capture.read_bytes()
    assert found(raw, marks) == [] and all(found(d, marks) == [] for d in streams.values())
    time.sleep(1.0)
    left = [(n, p) for n, group in pids.items() for p in group if alive(p)]
    assert left == []


CONTROL_A = """
import sys, threading, zenoh
from fleet_bus.session import router_config
keys, heard = set(), threading.Event()


def on(sample):
    keys.add(str(sample.key_expr))
    if keys >= {"fleet/status/auv3", "fleet/mission"}:
        heard.set()


with zenoh.open(router_config([sys.argv[1]])) as s, s.declare_subscriber("fleet/**", on):
    print("ready", flush=True)
    sys.exit(0 if heard.wait(30) else 1)
"""
CONTROL_B = """
import sys, time, zenoh
from fleet_bus.credentials import load_auth
from fleet_bus.mission import Mission
from fleet_bus.session import router_config
from fleet_bus.telemetry import Status
auv3 = load_auth(sys.argv[4], "auv3")
status = Status(12.0, "auv3", "transit", (1.0, 2.0, 3.0), 3000.0, 40.0, [1, 2], [3], 1, 0.0,
                0.0).encode()
with zenoh.open(router_config([sys.argv[1]], [sys.argv[2]])) as s:
    while True:
        s.put("fleet/status/auv3", auv3.seal("fleet/status/auv3", status))
        s.put("fleet/mission", Mission({"vehicles": []}, 7, sys.argv[3]).encode())
        time.sleep(0.2)
"""


def test_the_same_search_finds_the_mission_on_a_plain_link(hosts: TwoHosts,
                                                           tmp_path: Path) -> None:
    """The control: two open routers linked over plain TCP, auv3's signed status and a
    mission record from host B to a subscriber on host A; the capture shows them in clear."""
    env = _tools(tmp_path, hosts.b.cwd)
    run_id = write_run_credentials(tmp_path / "creds", ("auv3",))
    port_a, port_b = hosts.port_a + 3, hosts.port_b + 5
    capture = tmp_path / "plain.pcap"
    dump = Tcpdump(hosts.a.prefix, hosts.iface, capture, f"tcp port {port_a}")
    listen_a = f"tcp/{'0.0.0.0' if hosts.namespaces else '127.0.0.1'}:{port_a}"
    procs = []
    try:
        procs.append(_start(hosts.a, shlex.join(["python", "-c", CONTROL_A, listen_a]), env,
                            tmp_path / "a.log"))
        procs.append(_start(hosts.b, shlex.join([
            "python", "-c", CONTROL_B, f"tcp/127.0.0.1:{port_b}",
            f"tcp/{hosts.address_a}:{port_a}", run_id, str(tmp_path / "creds" / "auv3")]),
            env, tmp_path / "b.log"))
        assert procs[0].wait(60) == 0, (tmp_path / "a.log").read_text()
    finally:
        _stop(procs)
        dump.stop()
    marks = plaintext_markers(run_id, ("auv3",))
    seen = set(found(capture.read_bytes(), marks))
    assert {"run id", "key expressions' root", "key status/auv3", "key mission",
            "auv3 in msgpack", "auv3 signing an envelope", "field battery_s",
            "field scenario"} - seen == set()
