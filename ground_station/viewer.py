"""Where the recording goes: a native viewer, a locally served web viewer, an .rrd file, or
several at once (one `set_sinks` call). The network at sea is closed, so the web viewer is the
copy bundled with rerun-sdk, served from this machine; nothing is fetched from rerun.io.

The web viewer listens where it is told (``--web-host``, loopback by default) and the printed
URL is where it really listens. rerun-sdk's in-process ``serve_web_viewer`` always binds every
interface (0.0.0.0) and has no address parameter, so the page is served by the ``rerun``
binary that ships with rerun-sdk (``rerun --serve-web --bind HOST``), a child process that
serves the page only; the data stays in this process's gRPC server, bound to the same host.
The child dies with the station (``PR_SET_PDEATHSIG`` on Linux, and stopped at close).
"""

from __future__ import annotations

import errno
import importlib.util
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote

import rerun as rr
import rerun.blueprint as rrb

VIEWERS = ("native", "web", "none")
# Rows are sent to the viewer in chunks, one per entity per tick: a longer tick makes fewer,
# larger chunks (the viewer's cost is per chunk) at the price of that much more latency.
FLUSH_TICK_S = 2.0
SERVER_START_S = 10.0  # how long a server may take to listen before we give up on it
WILDCARD = ("0.0.0.0", "::", "")


class SinkError(RuntimeError):
    """A sink could not be opened (bad address, no free port, no rerun binary); the message
    says why in one line, for the operator."""


def has_display() -> bool:
    """Whether a desktop window can open here (an X11 or Wayland display is named)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def default_viewer() -> str:
    """The desktop viewer when there is a display to show it on, else the web viewer."""
    return "native" if has_display() and shutil.which("rerun") else "web"


def resolve_viewer(requested: str | None) -> tuple[str, str | None]:
    """The viewer to open for ``requested`` (None: the default) and, when it differs from what
    was asked, one line saying why: the native viewer needs a display and the ``rerun``
    binary, and without them the web viewer is served instead (a dashboard in a browser
    rather than none at all)."""
    if requested is None:
        return default_viewer(), None
    if requested == "native" and not has_display():
        return "web", ("no display (neither DISPLAY nor WAYLAND_DISPLAY is set): the native "
                       "viewer cannot open a window, serving the web viewer instead")
    if requested == "native" and not shutil.which("rerun"):
        return "web", ("the native viewer needs the rerun binary of rerun-sdk, not on PATH: "
                       "serving the web viewer instead")
    return requested, None


def check_rrd(path: Path | None) -> None:
    """An ``.rrd`` goes into a directory that exists (SinkError otherwise, in one line): a
    typo in the path is not a request to create directories."""
    if path is None:
        return
    if path.is_dir():
        raise SinkError(f"--rrd {path}: is a directory, not a file")
    if not path.parent.is_dir():
        raise SinkError(f"--rrd {path}: no such directory {str(path.parent)!r}")


def free_port(host: str = "127.0.0.1") -> int:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def _url_host(host: str) -> str:
    """How a browser reaches ``host``: a wildcard bind by this machine's name."""
    name = socket.gethostname() if host in WILDCARD else host
    return f"[{name}]" if ":" in name else name


def _connect_host(host: str) -> str:
    return {"0.0.0.0": "127.0.0.1", "": "127.0.0.1", "::": "::1"}.get(host, host)


def web_viewer_url(host: str, web_port: int, grpc_uri: str) -> str:
    """The page to open: the bundled viewer, told where the data is. WebGL because ships and
    CI machines rarely have a WebGPU-capable GPU."""
    return f"http://{_url_host(host)}:{web_port}/?url={quote(grpc_uri, safe='')}&renderer=webgl"


def grpc_uri(host: str, port: int) -> str:
    return f"rerun+http://{_url_host(host)}:{port}/proxy"


def pick_port(host: str, wanted: int, what: str) -> tuple[int, str]:
    """``wanted`` if it can be bound on ``host``, else a free one and a note saying so; 0 means
    any. Raises `SinkError` when ``host`` cannot be bound at all (not an address of this
    machine)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    try:
        with socket.socket(family) as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the servers bind
            s.bind((host, wanted))
            return int(s.getsockname()[1]), ""
    except OSError as exc:
        if exc.errno != errno.EADDRINUSE:
            raise SinkError(f"cannot listen on {host}:{wanted} for the {what}: "
                            f"{exc.strerror or exc}") from None
    port = free_port(host)
    return port, f"{what} port {wanted} on {host} is busy: using {port}"


def _listening(host: str, port: int) -> bool:
    try:
        with socket.create_connection((_connect_host(host), port), timeout=0.5):
            return True
    except OSError:
        return False


def rerun_binary() -> str:
    """The ``rerun`` executable shipped with rerun-sdk (the one its own ``rerun`` script runs)."""
    override = os.environ.get("RERUN_CLI_PATH")
    if override:
        return override
    spec = importlib.util.find_spec("rerun_cli")
    if spec is not None and spec.origin is not None:
        exe = Path(spec.origin).with_name("rerun" + (".exe" if sys.platform == "win32" else ""))
        if exe.is_file():
            return str(exe)
    raise SinkError("the rerun binary of rerun-sdk (rerun_cli) is missing: cannot serve the "
                    "web viewer")


# Runs in the child before it becomes the rerun binary: ask the kernel for SIGTERM when this
# process dies, however it dies, then exec (the request survives exec). A launcher is safer
# than preexec_fn, which may deadlock in a process with threads (Zenoh's).
_DIE_WITH_PARENT = (
    "import ctypes, os, signal, sys\n"
    "try:\n"
    "    ctypes.CDLL(None).prctl(1, signal.SIGTERM)\n"  # PR_SET_PDEATHSIG
    "except (OSError, AttributeError):\n"
    "    pass\n"
    "if os.getppid() != int(sys.argv[1]):\n"
    "    sys.exit(0)\n"
    "os.execv(sys.argv[2], sys.argv[2:])\n"
)


def serve_web_viewer(host: str, port: int, connect_to: str) -> tuple[subprocess.Popen, int, str]:
    """The bundled web viewer on ``host:port`` (a free port if busy), as a child process.
    Returns the process, the port it listens on and a note if the port changed."""
    exe = rerun_binary()
    wanted = port
    for _ in range(3):  # a port found free may be taken before the child binds it
        port, note = pick_port(host, wanted, "web viewer")
        err = tempfile.TemporaryFile()
        proc = subprocess.Popen(
            [sys.executable, "-c", _DIE_WITH_PARENT, str(os.getpid()), exe, "--serve-web",
             "--bind", host or "0.0.0.0", "--web-viewer-port", str(port), connect_to],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err)
        deadline = time.monotonic() + SERVER_START_S
        while time.monotonic() < deadline and proc.poll() is None:
            if _listening(host, port):
                err.close()
                return proc, port, note
            time.sleep(0.05)
        stop_process(proc)
        err.seek(0)
        why = err.read().decode(errors="replace").strip().splitlines()
        err.close()
        if not any("in use" in line for line in why):
            raise SinkError(f"the web viewer did not start on {host}:{port}: "
                            f"{why[-1] if why else 'no answer'}")
        wanted = 0
    raise SinkError(f"no free port for the web viewer on {host}")


def stop_process(proc: subprocess.Popen, grace_s: float = 3.0) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(grace_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@dataclass(frozen=True)
class ViewerOptions:
    viewer: str = "none"
    rrd: Path | None = None
    web_host: str = "127.0.0.1"  # where the web viewer and its gRPC server listen
    web_port: int = 9090  # 0: any free port; a busy one is replaced by a free one
    grpc_port: int = 0  # 0: any free port

    def __post_init__(self) -> None:
        if self.viewer not in VIEWERS:
            raise ValueError(f"viewer must be one of {VIEWERS}, got {self.viewer!r}")


@dataclass
class Sinks:
    """An open recording stream and what serves it."""

    rec: rr.RecordingStream
    url: str | None = None
    notes: list[str] = field(default_factory=list)  # e.g. a busy port replaced
    web_server: subprocess.Popen | None = None
    rrd: Path | None = None
    blueprint: rrb.Blueprint | None = None

    def close(self, compact: bool = True) -> None:
        """Flush everything (the .rrd footer included), stop the web server, and rewrite the
        .rrd in large chunks (`compact_rrd`)."""
        try:
            close_recording(self.rec)
        finally:
            if self.web_server is not None:
                stop_process(self.web_server)
        if compact and self.rrd is not None and self.rrd.exists():
            try:
                # rr's functions: the RecordingStream methods are these, bound in a way mypy
                # cannot follow ("does not accept self argument")
                app = rr.get_application_id(recording=self.rec)
                if app is None:
                    raise ValueError("the recording has no application id")
                compact_rrd(self.rrd, app, self.rec.get_recording_id(), self.blueprint)
            except Exception as exc:  # the uncompacted file is complete: keep it
                self.notes.append(f"{self.rrd} left uncompacted: {exc}")


def open_recording(application_id: str, recording_id: str, opts: ViewerOptions,
                   blueprint: rrb.Blueprint) -> Sinks:
    """A recording stream wired to the chosen sinks (and the web viewer URL in web mode).
    Raises `SinkError` with a one-line reason when a sink cannot be opened.

    With no sink at all the stream is disabled rather than buffering the mission in memory.
    """
    wants_sink = opts.viewer != "none" or opts.rrd is not None
    rec = rr.RecordingStream(application_id, recording_id=recording_id,
                             default_enabled=wants_sink,
                             batcher_config=rr.ChunkBatcherConfig(flush_tick=FLUSH_TICK_S))
    out = Sinks(rec, rrd=opts.rrd, blueprint=blueprint)
    if not wants_sink:
        return out
    rr.set_log_time_enabled(False, recording=rec)  # one timeline: the fleet's own sim_time
    try:
        _open_sinks(out, opts)
    except BaseException:
        out.close(compact=False)
        raise
    return out


def _open_sinks(out: Sinks, opts: ViewerOptions) -> None:
    rec = out.rec
    sinks: list = []
    host = opts.web_host if opts.viewer == "web" else "127.0.0.1"
    grpc_port, note = pick_port(host, opts.grpc_port, "gRPC")
    out.notes += [note] if note else []
    if opts.viewer == "web":
        sinks.append(rr.GrpcServerSink(bind_ip=host or "0.0.0.0", port=grpc_port))
    elif opts.viewer == "native":
        rr.spawn(port=grpc_port, connect=False, hide_welcome_screen=True)
        sinks.append(rr.GrpcSink(grpc_uri("127.0.0.1", grpc_port)))
    if opts.rrd is not None:
        check_rrd(opts.rrd)
        sinks.append(rr.FileSink(opts.rrd))
    rec.set_sinks(*sinks, default_blueprint=out.blueprint)
    if opts.viewer == "web":
        deadline = time.monotonic() + SERVER_START_S
        while not _listening(host, grpc_port):
            if time.monotonic() > deadline:
                raise SinkError(f"the gRPC server did not start on {host}:{grpc_port}")
            time.sleep(0.05)
        uri = grpc_uri(host, grpc_port)
        out.web_server, web_port, note = serve_web_viewer(host, opts.web_port, uri)
        out.notes += [note] if note else []
        if host in WILDCARD:
            out.notes.append(f"web viewer listening on all interfaces ({host or '0.0.0.0'})")
        out.url = web_viewer_url(host, web_port, uri)


def close_recording(rec: rr.RecordingStream) -> None:
    """Flush everything (the .rrd footer included) before the process goes."""
    if not rr.is_enabled(recording=rec):
        return
    rec.flush(timeout_sec=3.0)  # the launcher allows 5 s after SIGTERM
    rec.disconnect()


def compact_rrd(path: Path, application_id: str, recording_id: str,
                blueprint: rrb.Blueprint | None) -> None:
    """Rewrite ``path`` with Rerun's own chunk optimiser: the live stream is cut into a chunk
    per entity per second of wall time, each with its own schema, which is most of a
    recording's size; merged, the same rows take a fraction of it (and replay faster). The
    file is replaced only once the compacted copy is complete."""
    from rerun.chunk import OptimizationProfile, RrdReader

    store = RrdReader(path).stream().collect(optimize=OptimizationProfile.LIVE)
    tmp = path.with_name(f".{path.name}.compacting")
    rec = rr.RecordingStream(application_id, recording_id=recording_id, send_properties=False)
    try:
        if blueprint is not None:
            rec.set_sinks(rr.FileSink(tmp), default_blueprint=blueprint)
        else:
            rec.set_sinks(rr.FileSink(tmp))
        rec.send_chunks(store)
        rec.flush(timeout_sec=30.0)
        rec.disconnect()
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def rrd_for_run(path: Path, run_id: str) -> Path:
    """``path``, unless it already holds this run (the station restarted mid-mission): then
    the next free ``<stem>.partN.rrd`` beside it, so the first part is never overwritten.
    Rerun merges parts with the same recording id when they are opened together."""
    from rerun.chunk import RrdReader

    candidate, n = path, 1
    while candidate.exists():
        try:
            ids = {r.recording_id for r in RrdReader(candidate).recordings()}
        except Exception:  # unreadable or foreign file: ours to overwrite
            return candidate
        if run_id not in ids:
            return candidate
        n += 1
        candidate = path.with_name(f"{path.stem}.part{n}{path.suffix}")
    return candidate
