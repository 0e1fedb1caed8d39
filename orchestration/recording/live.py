"""Watching a recording live while its file is written: Rerun's script options ``--connect [--url URL]``
and ``--serve`` (``rerun.script_add_args``) beside the .rrd file, which stays the default and is
written the same either way.

This module imports no Rerun at its top: the command line sets ``ASKED`` (``ask``) before the
recording's writer process forks, so the child, which opens the files, sees the same request.
``RecordingFile`` has ``stream`` make its stream a ``Tee``: the file's stream as without live viewing,
and a second stream of the same recording, with the same blueprint, to the viewer. A viewer that goes
away is said in one line (``Watch``); the run and the file go on as before.
"""
from __future__ import annotations

import contextlib
import socket
import sys
from dataclasses import dataclass
from urllib.parse import urlsplit

DEFAULT_URL = "rerun+http://127.0.0.1:9876/proxy"  # rerun.GrpcSink's default
GRPC_PORT, WEB_PORT = 9876, 9090  # rerun.serve_grpc's and rerun.serve_web_viewer's defaults
CHECK_TIMEOUT = 0.5  # s a look at the viewer may take


@dataclass(frozen=True)
class Live:
    """What to stream besides the file: to a running viewer at ``connect`` (a URL), or ``serve`` a
    gRPC server and web viewer on ``grpc_port`` and ``web_port``."""

    connect: str | None = None
    serve: bool = False
    grpc_port: int = GRPC_PORT
    web_port: int = WEB_PORT


ASKED: Live | None = None  # set by the command line for the command's recordings (``ask``)
_WEB_VIEWER = False  # this process serves the web viewer already


def ask(live: Live | None) -> None:
    """Stream this process's (and its writer's) recordings as ``live`` says (Rerun's own log lines about
    a viewer that went away are off: ``orchestration.recording``)."""
    global ASKED
    ASKED = live


def of_arguments(connect: bool, url: str | None, serve: bool) -> Live | None:
    """The ``Live`` of the command line's ``--connect``, ``--url`` and ``--serve`` (None: the file only)."""
    if not (connect or serve):
        return None
    return Live(connect=(url or DEFAULT_URL) if connect else None, serve=serve)


def check_url(text: str) -> str:
    """``--url``: Rerun's form, ``rerun+http://host:port/proxy`` (schemes rerun, rerun+http, rerun+https)."""
    parts = urlsplit(text)
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.scheme not in ("rerun", "rerun+http", "rerun+https") or not parts.hostname or parts.path != "/proxy":
        raise ValueError(f"--url {text!r} is not a Rerun viewer's URL like {DEFAULT_URL}")
    if port is None and parts.scheme == "rerun+http":
        raise ValueError(f"--url {text!r} names no port (like {DEFAULT_URL})")
    return text


def stream(live: Live | None, file_stream, blueprint, path) -> object:
    """``file_stream`` itself (nothing asked), or a ``Tee`` of it and a stream of the same recording to the
    sinks ``live`` asks for, with ``blueprint`` (imports Rerun). The viewer of ``--connect`` only if it
    answers now (Rerun's sink to a viewer it never reached fails every flush after 6 s); serving also
    starts the web viewer, whose address is printed (one line)."""
    if live is None:
        return file_stream
    import rerun as rr

    global _WEB_VIEWER
    watch = Watch(live, path)
    sinks = []
    if live.connect and watch.seen:
        sinks.append(rr.GrpcSink(live.connect))
    if live.serve:
        server = rr.GrpcServerSink(port=live.grpc_port)
        sinks.append(server)
        if not _WEB_VIEWER:  # one per process, for all its recordings
            rr.serve_web_viewer(web_port=live.web_port, open_browser=False, connect_to=server.uri)
            _WEB_VIEWER = True
        print(f"sotc-cosim: live: web viewer at http://127.0.0.1:{live.web_port} (gRPC {server.uri})",
              file=sys.stderr, flush=True)
    if not sinks:
        return file_stream
    other = rr.RecordingStream(application_id=file_stream.get_application_id(),
                               recording_id=file_stream.get_recording_id())
    other.set_sinks(*sinks, default_blueprint=blueprint)
    return Tee(file_stream, other, watch)


class Tee:
    """A ``rr.RecordingStream`` to the file and one to the live viewer, as one: every call goes to the
    file's stream as before (its errors are the caller's), then to the live one, whose failure (Rerun
    raises "gRPC connection severed" on a flush once the viewer went away) ends the live stream, said
    once by ``watch``. ``flush`` also has ``watch`` look at the viewer."""

    def __init__(self, file_stream, live_stream, watch: "Watch"):
        self.file, self.live, self.watch = file_stream, live_stream, watch

    def __getattr__(self, name: str):
        own = getattr(self.file, name)
        if not callable(own):
            return own

        def both(*args, **kwargs):
            out = own(*args, **kwargs)
            if self.live is not None:
                try:  # a flush is not waited for: a slow viewer does not hold the run
                    getattr(self.live, name)(*args, **({"timeout_sec": 0} if name == "flush" else kwargs))
                except Exception:
                    self.watch.lost()
            if name == "flush":
                self.watch.check()
            if self.watch.gone and self.live is not None:
                self.live, live = None, self.live
                with contextlib.suppress(Exception):
                    live.disconnect()
            return out

        return both


def _address(url: str) -> tuple[str, int]:
    parts = urlsplit(url)
    return parts.hostname or "127.0.0.1", parts.port or (443 if parts.scheme == "rerun+https" else GRPC_PORT)


class Watch:
    """Whether the viewer ``--connect`` streams to is there: looked at (a TCP connection to its address)
    when made and by ``check`` after each flush; once it is not there (went away, or did not answer at
    the start: then it is not streamed to), one line says so, and it is not looked at again. A viewer
    that goes away after it was reached neither blocks nor fails Rerun's flushes."""

    def __init__(self, live: Live | None, path):
        self.url = live.connect if live is not None else None
        self.path = path
        self.seen = False  # the viewer answered once
        self.gone = False
        self.check()

    def _there(self) -> bool:
        try:
            socket.create_connection(_address(self.url), timeout=CHECK_TIMEOUT).close()
            return True
        except OSError:
            return False

    def check(self) -> None:
        """Look at the viewer of ``--connect`` (a TCP connection)."""
        if self.url is None or self.gone:
            return
        if self._there():
            self.seen = True
        else:
            self.lost()

    def lost(self) -> None:
        """The viewer is not there (once: said in one line)."""
        if self.gone:
            return
        self.gone = True
        what = "went away; the run goes on and" if self.seen else "does not answer, not streamed to;"
        print(f"sotc-cosim: live: the viewer at {self.url} {what} {self.path} is written in full",
              file=sys.stderr, flush=True)
