"""Where the recording goes: a native viewer, a locally served web viewer, an .rrd file, or
several at once (one `set_sinks` call). The network at sea is closed, so the web viewer is the
copy bundled with rerun-sdk, served from this process; nothing is fetched from rerun.io.
"""

from __future__ import annotations

import os
import shutil
import socket
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

import rerun as rr
import rerun.blueprint as rrb

VIEWERS = ("native", "web", "none")


def default_viewer() -> str:
    """The desktop viewer when there is a display to show it on, else the web viewer."""
    has_display = bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return "native" if has_display and shutil.which("rerun") else "web"


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def web_viewer_url(host: str, web_port: int, grpc_uri: str) -> str:
    """The page to open: the bundled viewer, told where the data is. WebGL because ships and
    CI machines rarely have a WebGPU-capable GPU."""
    return f"http://{host}:{web_port}/?url={quote(grpc_uri, safe='')}&renderer=webgl"


@dataclass(frozen=True)
class ViewerOptions:
    viewer: str = "none"
    rrd: Path | None = None
    host: str = "127.0.0.1"
    web_port: int = 9090  # 0: any free port
    grpc_port: int = 9876  # 0: any free port

    def __post_init__(self) -> None:
        if self.viewer not in VIEWERS:
            raise ValueError(f"viewer must be one of {VIEWERS}, got {self.viewer!r}")


def open_recording(application_id: str, recording_id: str, opts: ViewerOptions,
                   blueprint: rrb.Blueprint) -> tuple[rr.RecordingStream, str | None]:
    """A recording stream wired to the chosen sinks, and the web viewer URL (web mode only).

    With no sink at all the stream is disabled rather than buffering the mission in memory.
    """
    wants_sink = opts.viewer != "none" or opts.rrd is not None
    rec = rr.RecordingStream(application_id, recording_id=recording_id,
                             default_enabled=wants_sink)
    if not wants_sink:
        return rec, None
    rr.set_log_time_enabled(False, recording=rec)  # one timeline: the fleet's own sim_time
    sinks: list = []
    url = None
    grpc_port = opts.grpc_port or free_port(opts.host)
    grpc_sink = None
    if opts.viewer == "web":
        grpc_sink = rr.GrpcServerSink(bind_ip=opts.host, port=grpc_port)
        sinks.append(grpc_sink)
    elif opts.viewer == "native":
        rr.spawn(port=grpc_port, connect=False, hide_welcome_screen=True)
        sinks.append(rr.GrpcSink(f"rerun+http://127.0.0.1:{grpc_port}/proxy"))
    if opts.rrd is not None:
        opts.rrd.parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(opts.rrd))
    rec.set_sinks(*sinks, default_blueprint=blueprint)
    if grpc_sink is not None:
        web_port = opts.web_port or free_port(opts.host)
        rr.serve_web_viewer(web_port=web_port, open_browser=False, connect_to=grpc_sink.uri)
        url = web_viewer_url(opts.host, web_port, grpc_sink.uri)
    return rec, url


def close_recording(rec: rr.RecordingStream) -> None:
    """Flush everything (the .rrd footer included) before the process goes."""
    if not rec.is_enabled():
        return
    rec.flush(timeout_sec=3.0)  # the launcher allows 5 s after SIGTERM
    rec.disconnect()


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
