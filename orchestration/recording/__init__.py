"""Streaming runs into Rerun recordings (.rrd) with a stored blueprint of the paper's figures.

Rerun's file writer logs a failed write to stderr itself; ``recording.writer.RecordingFile`` reports it
as one ``OutputError`` instead, and its gRPC client logs a live viewer that went away, which
``recording.live`` says in one line: those log lines are off unless the user sets ``RUST_LOG``."""
import os
from pathlib import Path

from orchestration.paths import OUTPUTS, magic_kind

os.environ.setdefault("RUST_LOG", "warn,re_log_encoding::rrd::file_sink=off,re_sdk::recording_stream=off,"
                                  "re_grpc_client=off")

# Samples per block handed over by the master (and flushed to the file): chosen by
# ``sotc-cosim bench recording``, see README "Recordings".
BLOCK_SIZE = 1000
# Rerun's files start with "RRF" and the version of their encoding (RRF2 for Rerun 0.41): what a
# --recording replaces without --force
RRD = magic_kind("a Rerun recording (.rrd)", b"RRF")


def default_recording_path(scenario_name: str) -> Path:
    return OUTPUTS / f"{scenario_name.replace('/', '_')}.rrd"
