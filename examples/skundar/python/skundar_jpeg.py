"""A tiny baseline JPEG codec for Skundar's synthetic camera (no image library needed).

The camera renders its picture in 8x8 blocks of flat grey, so every block is exactly its DC
coefficient: the encoder writes a valid baseline, grayscale JFIF file (any viewer opens it)
whose AC part is one end-of-block code per block. The decoder reads such files back (any
baseline grayscale JPEG with Huffman tables, keeping the DC term of each block: the block's
mean brightness), which is all the off-board vision needs.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence

#: Standard luminance DC table (ITU T.81, K.3): code lengths 1..16 and the symbols.
_DC_BITS = (0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0)
_DC_VALS = tuple(range(12))
#: An AC table with one symbol, end-of-block (0x00), code "0".
_AC_BITS = (1,) + (0,) * 15
_AC_VALS = (0,)
#: DC quantizer: a block of mean m has DC = 8 * (m - 128) / 8.
_Q0 = 8


class JpegError(ValueError):
    """The bytes are not a JPEG this decoder reads."""


def _codes(bits: Sequence[int], vals: Sequence[int]) -> dict[int, tuple[int, int]]:
    """Canonical Huffman codes: symbol -> (code, length)."""
    out: dict[int, tuple[int, int]] = {}
    code, k = 0, 0
    for length, count in enumerate(bits, start=1):
        for _ in range(count):
            out[vals[k]] = (code, length)
            code, k = code + 1, k + 1
        code <<= 1
    return out


class _BitWriter:
    def __init__(self) -> None:
        self.out = bytearray()
        self.acc, self.n = 0, 0

    def put(self, value: int, length: int) -> None:
        self.acc, self.n = (self.acc << length) | (value & ((1 << length) - 1)), self.n + length
        while self.n >= 8:
            self.n -= 8
            byte = (self.acc >> self.n) & 0xFF
            self.out.append(byte)
            if byte == 0xFF:
                self.out.append(0)  # byte stuffing
        self.acc &= (1 << self.n) - 1

    def flush(self) -> bytes:
        if self.n:
            self.put((1 << (8 - self.n)) - 1, 8 - self.n)  # pad with ones
        return bytes(self.out)


def _segment(marker: int, body: bytes) -> bytes:
    return struct.pack(">HH", 0xFF00 | marker, len(body) + 2) + body


def encode(blocks: Sequence[Sequence[int]]) -> bytes:
    """Encode rows of block brightnesses (0..255, one per 8x8 block) as a baseline JPEG."""
    rows, cols = len(blocks), len(blocks[0])
    dqt = bytes([0]) + bytes([_Q0] + [1] * 63)
    sof = struct.pack(">BHHB", 8, rows * 8, cols * 8, 1) + bytes([1, 0x11, 0])
    dht = bytes([0x00, *_DC_BITS, *_DC_VALS]) + bytes([0x10, *_AC_BITS, *_AC_VALS])
    sos = bytes([1, 1, 0x00, 0, 63, 0])
    dc, ac = _codes(_DC_BITS, _DC_VALS), _codes(_AC_BITS, _AC_VALS)
    bits, pred = _BitWriter(), 0
    for row in blocks:
        for mean in row:
            value = round(8 * (max(0, min(255, mean)) - 128) / _Q0)
            diff, pred = value - pred, value
            size = abs(diff).bit_length()
            bits.put(*dc[size])
            if size:
                bits.put(diff if diff > 0 else diff + (1 << size) - 1, size)
            bits.put(*ac[0])
    jfif = b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00"
    return b"".join(
        (
            b"\xff\xd8",
            _segment(0xE0, jfif),
            _segment(0xDB, dqt),
            _segment(0xC0, sof),
            _segment(0xC4, dht),
            _segment(0xDA, sos),
            bits.flush(),
            b"\xff\xd9",
        )
    )


def _segments(data: bytes) -> Iterator[tuple[int, bytes, int]]:
    """Yield (marker, body, end offset) up to and including SOS."""
    if data[:2] != b"\xff\xd8":
        raise JpegError("no SOI marker")
    pos = 2
    while pos + 4 <= len(data):
        if data[pos] != 0xFF:
            raise JpegError(f"no marker at offset {pos}")
        marker, length = data[pos + 1], struct.unpack(">H", data[pos + 2 : pos + 4])[0]
        end = pos + 2 + length
        if length < 2 or end > len(data):
            raise JpegError("truncated segment")
        yield marker, data[pos + 4 : end], end
        if marker == 0xDA:
            return
        pos = end
    raise JpegError("no SOS marker")


def _entropy_bits(data: bytes) -> Iterator[int]:
    i = 0
    while i < len(data):
        byte = data[i]
        if byte == 0xFF:
            if i + 1 < len(data) and data[i + 1] == 0:
                i += 1
            else:
                return  # a marker: the end of the scan
        for shift in range(7, -1, -1):
            yield (byte >> shift) & 1
        i += 1


def _tables(body: bytes) -> dict[int, dict[tuple[int, int], int]]:
    tables: dict[int, dict[tuple[int, int], int]] = {}
    pos = 0
    while pos < len(body):
        tc_th, bits = body[pos], body[pos + 1 : pos + 17]
        vals = body[pos + 17 : pos + 17 + sum(bits)]
        tables[tc_th] = {cl: v for v, cl in _codes(bits, vals).items()}
        pos += 17 + sum(bits)
    return tables


def decode_dc(data: bytes) -> list[list[int]]:
    """Decode a baseline grayscale JPEG into rows of block brightnesses (the DC terms)."""
    height = width = q0 = 0
    huff: dict[int, dict[tuple[int, int], int]] = {}
    scan_start = 0
    for marker, body, end in _segments(data):
        if marker == 0xDB:
            q0 = body[1]
        elif marker == 0xC0:
            _, height, width, ncomp = struct.unpack(">BHHB", body[:6])
            if ncomp != 1:
                raise JpegError("only grayscale frames are read")
        elif marker in (0xC1, 0xC2, 0xC3):
            raise JpegError("only baseline frames are read")
        elif marker == 0xC4:
            huff.update(_tables(body))
        elif marker == 0xDA:
            scan_start = end
    if not (height and width and q0) or 0x00 not in huff or 0x10 not in huff:
        raise JpegError("missing frame header, tables or quantizer")
    bits = _entropy_bits(data[scan_start:])
    return _scan(bits, huff[0x00], huff[0x10], (height + 7) // 8, (width + 7) // 8, q0)


def _symbol(bits: Iterator[int], table: dict[tuple[int, int], int]) -> int:
    code = 0
    for length in range(1, 17):
        code = (code << 1) | next(bits)
        if (code, length) in table:
            return table[(code, length)]
    raise JpegError("bad Huffman code")


def _receive(bits: Iterator[int], size: int) -> int:
    value = 0
    for _ in range(size):
        value = (value << 1) | next(bits)
    return value - (1 << size) + 1 if size and value < (1 << (size - 1)) else value


def _scan(
    bits: Iterator[int],
    dc: dict[tuple[int, int], int],
    ac: dict[tuple[int, int], int],
    rows: int,
    cols: int,
    q0: int,
) -> list[list[int]]:
    out: list[list[int]] = []
    pred = 0
    try:
        for _ in range(rows):
            row: list[int] = []
            for _ in range(cols):
                pred += _receive(bits, _symbol(bits, dc))
                k = 1
                while k < 64:  # skip the AC terms
                    rs = _symbol(bits, ac)
                    if rs == 0:
                        break
                    _receive(bits, rs & 0x0F)
                    k += (rs >> 4) + 1
                row.append(max(0, min(255, round(pred * q0 / 8 + 128))))
            out.append(row)
    except StopIteration:
        raise JpegError("scan data ends early") from None
    return out
