"""Chunked recordings of tactile frames (with optional sensor poses) and their replay.

File layout (all integers little-endian; the full table is in ``docs/hardware.md``)::

    file header   "TBTREC01" | u16 version=1 | u16 rows | u16 cols | u16 flags=0
                  | u32 M | M bytes of UTF-8 JSON metadata | u32 CRC-32 of everything before
    chunk         "CHNK" | u32 n frames | u32 payload bytes L | u32 CRC-32 of payload | payload
    payload       f8[n] timestamps (s) | f8[n,4,4] poses (NaN = none) | u4[n] device timestamps
                  | u2[n,rows,cols] raw counts | u1[n] sensor ids

The recorder writes the header at once and each chunk with a single ``write`` followed by a
flush, never a blob at the end: a recorder killed at any moment (even SIGKILL) leaves a file
whose complete chunks all read back; only the torn last chunk is lost.  Readers tolerate a
torn tail (:func:`replay` warns about it with a :class:`RecordingWarning`) and raise
:class:`RecordingError` naming the file and byte offset on corruption.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import struct
import time
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from tactile_bt.errors import RecordingError, RecordingWarning
from tactile_bt.defaults import COLS, ROWS
from tactile_bt.sense.hardware.protocol import TactileFrame

MAGIC = b"TBTREC01"
FORMAT_VERSION = 1
CHUNK_MAGIC = b"CHNK"
_HEAD = struct.Struct("<8sHHHHI")
_CHUNK = struct.Struct("<4sIII")


def torn_tail_message(path: str | Path, offset: int, frames: int) -> str:
    """The warning about a recording whose last chunk is torn at byte ``offset``."""
    return (f"{path}: the recording ends in a torn chunk at byte {offset}; "
            f"replaying the {frames} complete frames")


def _pose_matrix(pose: Any) -> np.ndarray:
    """None -> NaN; (4, 4) homogeneous matrix; or (7,) ``[x, y, z, qx, qy, qz, qw]`` (m, unit quaternion)."""
    if pose is None:
        return np.full((4, 4), np.nan)
    p = np.asarray(pose, dtype=float)
    if p.shape == (4, 4):
        return p
    if p.shape == (7,):
        from scipy.spatial.transform import Rotation

        m = np.eye(4)
        m[:3, :3] = Rotation.from_quat(p[3:]).as_matrix()
        m[:3, 3] = p[:3]
        return m
    raise ValueError(f"pose must be a 4x4 matrix or [x, y, z, qx, qy, qz, qw], got shape {p.shape}")


def _frame_bytes(rows: int, cols: int) -> int:
    return 8 + 128 + 4 + 2 * rows * cols + 1


class Recorder:
    """Write frames into a chunked recording; use as a context manager.

    Parameters
    ----------
    path
        Output file (overwritten).
    rows, cols
        Frame shape.
    metadata
        JSON-serialisable dict stored in the header (port, rate, cell order, ...).
    chunk_frames, chunk_seconds
        A chunk is written when it holds this many frames or is this old (wall seconds).
    fsync
        Also ``os.fsync`` after every chunk (survives power loss, not just process death).
    """

    def __init__(self, path: str | Path, rows: int = ROWS, cols: int = COLS, metadata: dict | None = None,
                 chunk_frames: int = 256, chunk_seconds: float = 0.25, fsync: bool = False) -> None:
        self.path, self.rows, self.cols = Path(path), rows, cols
        self.chunk_frames, self.chunk_seconds, self.fsync = max(1, int(chunk_frames)), chunk_seconds, fsync
        self.frames_written = self.chunks_written = 0
        meta = {"rows": rows, "cols": cols, "created": _dt.datetime.now(_dt.timezone.utc).isoformat()}
        meta.update(metadata or {})
        blob = json.dumps(meta, sort_keys=True).encode()
        head = _HEAD.pack(MAGIC, FORMAT_VERSION, rows, cols, 0, len(blob)) + blob
        self._file = open(self.path, "wb")
        self._file.write(head + struct.pack("<I", zlib.crc32(head)))
        self._sync()
        self._reset()

    def _reset(self) -> None:
        # one tuple (time, pose, device time, values, sensor id) per frame, appended in one step:
        # a Ctrl-C or SIGTERM between two appends to parallel lists would leave a frame half
        # buffered, and the last chunk would declare more frames than its payload holds
        self._frames: list[tuple] = []
        self._started = time.monotonic()

    def _sync(self) -> None:
        self._file.flush()
        if self.fsync:
            os.fsync(self._file.fileno())

    def write(self, frame: TactileFrame | np.ndarray, pose: Any = None, timestamp: float | None = None) -> None:
        """Append one frame (a :class:`TactileFrame` or a raw-count array) and its pose.

        ``timestamp`` (s) overrides the frame's; an array without one gets ``time.monotonic()``.
        """
        if self._file.closed:
            raise ValueError(f"recorder for {self.path} is closed")
        values = np.asarray(getattr(frame, "values", frame))
        if values.shape != (self.rows, self.cols):
            raise ValueError(f"frame shape {values.shape}, recording expects ({self.rows}, {self.cols})")
        if timestamp is None:
            timestamp = getattr(frame, "timestamp", None)
        matrix = _pose_matrix(pose)  # validate everything before appending anything
        self._frames.append((time.monotonic() if timestamp is None else float(timestamp), matrix,
                             int(getattr(frame, "device_timestamp", 0)) & 0xFFFFFFFF, values.astype(np.uint16),
                             int(getattr(frame, "sensor_id", 1)) & 0xFF))
        if len(self._frames) >= self.chunk_frames or time.monotonic() - self._started >= self.chunk_seconds:
            self.flush()

    def flush(self) -> None:
        """Write the buffered frames as one chunk now (no-op when empty).

        All or nothing: interrupted (a Ctrl-C, or SIGTERM turned into one) before the chunk is
        on disk, the file is cut back to where the chunk began and the frames stay buffered, so
        that :meth:`close` writes them once, neither lost nor twice."""
        n = len(self._frames)
        if n == 0 or self._file.closed:
            return
        frames, self._frames = self._frames, []
        start = None
        try:
            t, pose, dev, values, sid = zip(*frames)
            payload = b"".join((
                np.asarray(t, dtype="<f8").tobytes(),
                np.asarray(pose, dtype="<f8").tobytes(),
                np.asarray(dev, dtype="<u4").tobytes(),
                np.asarray(values, dtype="<u2").tobytes(),
                np.asarray(sid, dtype="u1").tobytes(),
            ))
            start = self._file.tell()
            self._file.write(_CHUNK.pack(CHUNK_MAGIC, n, len(payload), zlib.crc32(payload)) + payload)
            self._sync()
        except BaseException:
            self._frames = frames + self._frames
            if start is not None:
                self._file.seek(start)
                self._file.truncate()
            raise
        self.frames_written += n
        self.chunks_written += 1
        self._started = time.monotonic()

    def close(self) -> None:
        """Write the last chunk and close the file (idempotent)."""
        if not self._file.closed:
            self.flush()
            self._file.close()

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(eq=False)
class RecordingChunk:
    """One chunk's arrays; ``offset`` is its byte offset in the file."""

    offset: int
    timestamps: np.ndarray
    poses: np.ndarray
    device_timestamps: np.ndarray
    values: np.ndarray
    sensor_ids: np.ndarray


@dataclass(eq=False)
class Recording:
    """A whole recording in memory; unpacks as ``values, timestamps, poses = recording``.

    ``values`` (N, rows, cols) uint16 raw counts, ``timestamps`` (N,) s, ``poses`` (N, 4, 4)
    (NaN where none was given), ``torn_tail_bytes`` the bytes of an incomplete last chunk and
    ``torn_tail_offset`` its byte offset (None when the file ends with a complete chunk).
    """

    path: Path
    rows: int
    cols: int
    metadata: dict
    values: np.ndarray
    timestamps: np.ndarray
    poses: np.ndarray
    device_timestamps: np.ndarray
    sensor_ids: np.ndarray
    chunks: int = 0
    torn_tail_bytes: int = 0
    torn_tail_offset: int | None = None

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.values, self.timestamps, self.poses))

    def __len__(self) -> int:
        return len(self.timestamps)


def read_header(path: str | Path) -> tuple[int, int, dict, int]:
    """Check the file header; return ``(rows, cols, metadata, offset of the first chunk)``."""
    path = Path(path)
    with open(path, "rb") as fh:
        head = fh.read(_HEAD.size)
        if len(head) < 8 or head[:8] != MAGIC:
            raise RecordingError(f"{path}: not a tactile_bt recording: bad magic {head[:8]!r} at byte offset 0")
        if len(head) < _HEAD.size:
            raise RecordingError(f"{path}: truncated file header at byte offset {len(head)}")
        _magic, version, rows, cols, _flags, mlen = _HEAD.unpack(head)
        if version != FORMAT_VERSION:
            raise RecordingError(f"{path}: unsupported format version {version} at byte offset 8")
        blob = fh.read(mlen)
        crc = fh.read(4)
    end = _HEAD.size + mlen
    if len(blob) < mlen or len(crc) < 4:
        raise RecordingError(f"{path}: truncated file header (metadata) at byte offset {_HEAD.size + len(blob)}")
    if struct.unpack("<I", crc)[0] != zlib.crc32(head + blob):
        raise RecordingError(f"{path}: corrupted file header: CRC mismatch at byte offset {end}")
    try:
        meta = json.loads(blob.decode())
    except ValueError as exc:
        raise RecordingError(f"{path}: corrupted metadata at byte offset {_HEAD.size}: {exc}") from None
    return rows, cols, meta, end + 4


def iter_chunks(path: str | Path, strict: bool = True, _tail: list | None = None) -> Iterator[RecordingChunk]:
    """Yield the complete chunks of a recording in order, lazily.

    A torn last chunk is skipped silently (``_tail`` receives ``(offset, bytes)`` of what
    was not read).  A corrupted chunk raises :class:`RecordingError` naming the byte offset,
    or with ``strict=False`` ends the iteration there.
    """
    path = Path(path)
    rows, cols, _meta, off = read_header(path)
    size = path.stat().st_size
    per = _frame_bytes(rows, cols)
    with open(path, "rb") as fh:
        fh.seek(off)
        while off < size:
            head = fh.read(_CHUNK.size)
            if len(head) < _CHUNK.size:
                break  # torn tail
            magic, n, length, crc = _CHUNK.unpack(head)
            problem = None
            if magic != CHUNK_MAGIC:
                problem = f"bad chunk magic {magic!r}"
            elif length != n * per:
                problem = f"chunk of {n} frames declares {length} payload bytes, expected {n * per}"
            elif off + _CHUNK.size + length > size:
                break  # torn tail
            else:
                payload = fh.read(length)
                if zlib.crc32(payload) != crc:
                    problem = "chunk payload CRC mismatch"
            if problem:
                if strict:
                    raise RecordingError(f"{path}: corrupted chunk at byte offset {off}: {problem}")
                break
            yield _unpack(off, payload, n, rows, cols)
            off += _CHUNK.size + length
    if _tail is not None:
        _tail.append((off, size - off))


def _unpack(off: int, payload: bytes, n: int, rows: int, cols: int) -> RecordingChunk:
    cuts = np.cumsum([0, 8 * n, 128 * n, 4 * n, 2 * rows * cols * n, n])
    part = [payload[cuts[k] : cuts[k + 1]] for k in range(5)]
    return RecordingChunk(
        offset=off,
        timestamps=np.frombuffer(part[0], dtype="<f8").astype(float),
        poses=np.frombuffer(part[1], dtype="<f8").reshape(n, 4, 4).astype(float),
        device_timestamps=np.frombuffer(part[2], dtype="<u4").astype(np.uint32),
        values=np.frombuffer(part[3], dtype="<u2").reshape(n, rows, cols).astype(np.uint16),
        sensor_ids=np.frombuffer(part[4], dtype="u1").astype(np.uint8),
    )


def read_recording(path: str | Path, strict: bool = True) -> Recording:
    """Read a whole recording; a torn last chunk is left out (see ``torn_tail_bytes``)."""
    path = Path(path)
    rows, cols, meta, _off = read_header(path)
    tail: list[tuple[int, int]] = []
    chunks = list(iter_chunks(path, strict=strict, _tail=tail))
    torn_at, torn_bytes = tail[0] if tail and tail[0][1] > 0 else (None, 0)

    def cat(name: str, shape: tuple, dtype: Any) -> np.ndarray:
        parts = [getattr(c, name) for c in chunks]
        return np.concatenate(parts) if parts else np.zeros((0, *shape), dtype=dtype)

    return Recording(
        path=path, rows=rows, cols=cols, metadata=meta,
        values=cat("values", (rows, cols), np.uint16), timestamps=cat("timestamps", (), float),
        poses=cat("poses", (4, 4), float), device_timestamps=cat("device_timestamps", (), np.uint32),
        sensor_ids=cat("sensor_ids", (), np.uint8), chunks=len(chunks), torn_tail_bytes=torn_bytes,
        torn_tail_offset=torn_at,
    )


def replay(path: str | Path, speed: float | None = None, *, with_poses: bool = False,
           strict: bool = True) -> Iterator[TactileFrame | tuple[TactileFrame, np.ndarray]]:
    """Yield the recorded frames in order, with their recorded timestamps.

    Parameters
    ----------
    speed
        ``None``: as fast as the consumer takes them; ``x > 0``: paced at ``x`` times the
        recorded rate (1.0 = recorded speed).  The frames are identical either way.
    with_poses
        Yield ``(frame, pose)`` with the (4, 4) pose (NaN if none was recorded).

    A torn last chunk ends the replay with a :class:`RecordingWarning` after the last complete
    frame.
    """
    if speed is not None and not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"speed must be a finite number > 0 or None, got {speed}")
    t0 = w0 = None
    tail: list[tuple[int, int]] = []
    frames = 0
    for chunk in iter_chunks(path, strict=strict, _tail=tail):
        frames += len(chunk.timestamps)
        for k in range(len(chunk.timestamps)):
            t = float(chunk.timestamps[k])
            if speed is not None:
                if t0 is None:
                    t0, w0 = t, time.monotonic()
                else:
                    delay = w0 + (t - t0) / speed - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)
            frame = TactileFrame(chunk.values[k], t, int(chunk.sensor_ids[k]), int(chunk.device_timestamps[k]))
            yield (frame, chunk.poses[k]) if with_poses else frame
    if strict and tail and tail[0][1] > 0:
        warnings.warn(RecordingWarning(torn_tail_message(path, tail[0][0], frames)), stacklevel=2)
