"""Streaming runs into Rerun recordings (.rrd) with a stored blueprint of the paper's figures.

Rerun's file writer logs a failed write to stderr itself; ``recording.writer.RecordingFile`` reports it
as one ``OutputError`` instead, so that log line is off unless the user sets ``RUST_LOG``."""
import os

os.environ.setdefault("RUST_LOG", "warn,re_log_encoding::rrd::file_sink=off,re_sdk::recording_stream=off")
