"""Resampling to the acoustic model's 16 kHz: a whole signal at once, a long
one block by block (read from a file a piece at a time), or a stream of
decoded blocks as they come (whose length is known only at its end).  Every
way gives the same samples for the same signal."""

from __future__ import annotations

import math

import numpy as np

MODEL_RATE = 16000


def _fast_length(n: int) -> int:
    """Smallest 2^a 3^b 5^c >= n, a length the FFT handles quickly."""
    best = 1 << (n - 1).bit_length()
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            p = p35
            while p < n:
                p *= 2
            best = min(best, p)
            p35 *= 3
        p5 *= 5
    return best


def _resample_whole(samples: np.ndarray, rate: float, target: int) -> np.ndarray:
    n = len(samples)
    n_out = int(round(n * target / rate))
    if float(rate) == int(rate):
        # Both padded lengths whole multiples of the rates' ratio: the new
        # grid is exactly the old one rescaled, with no drift along the clip.
        g = math.gcd(int(rate), target)
        down, up = int(rate) // g, target // g
        m = _fast_length(-(-(n + int(rate // 10)) // down))
        pad, pad_out = down * m, up * m
    else:
        pad = _fast_length(n + int(rate // 10))
        pad_out = int(round(pad * target / rate))
    spec = np.fft.rfft(samples, pad)
    keep = pad_out // 2 + 1
    if keep <= len(spec):
        spec = spec[:keep]
    else:
        spec = np.concatenate([spec, np.zeros(keep - len(spec), spec.dtype)])
    out = np.fft.irfft(spec, pad_out) * (pad_out / pad)
    return out[:n_out]


#: Blocks for long signals: FFTs of ~2^17 samples stay in cache, and the
#: margins (discarded) keep each block's edges away from the output.
_BLOCK = 1 << 17
_MARGIN = 4096


def resample(samples: np.ndarray, rate: float, target: int = MODEL_RATE) -> np.ndarray:
    """Band-limited resampling by FFT (the spectrum is cut at the new Nyquist
    frequency).  Zero padding to a fast length avoids slow prime-length FFTs
    and wrap-around at the ends.  Long signals at an integer rate go block by
    block, each block cut on a sample both rates share, with overlapping
    margins thrown away: the same result, several times faster."""
    samples = np.asarray(samples)
    if samples.dtype != np.float32:
        samples = samples.astype(np.float64)
    if int(round(rate)) == target:
        return samples.astype(np.float32)
    n = len(samples)
    if n == 0:
        return np.zeros(0, np.float32)
    if n <= 2 * _BLOCK or float(rate) != int(rate):
        return _resample_whole(samples.astype(np.float64), rate, target).astype(np.float32)
    # Converted to 64 bits a block at a time: no 64-bit copy of a long signal.
    return resample_blocks(lambda a, b: samples[a:b].astype(np.float64), n, int(rate), target)


def resample_blocks(read, n: int, rate: int, target: int = MODEL_RATE) -> np.ndarray:
    """:func:`resample` of a long signal of ``n`` samples at an integer
    rate, read block by block: ``read(a, b)`` returns samples a..b as
    float64 (a file can be read a piece at a time)."""
    blocks = BlockResampler(read, n, rate, target)
    out = np.empty(blocks.n_out, np.float32)
    for j in range(blocks.n_blocks):
        o0 = j * blocks.per_block
        y = blocks.block(j)
        out[o0:o0 + len(y)] = y
    return out


class BlockResampler:
    """The blocks :func:`resample` cuts a long signal at an integer rate
    into: block ``j`` of the output (``per_block`` samples, the last one
    shorter) from the input samples ``read(a, b)`` returns (float64)."""

    def __init__(self, read, n: int, rate: int, target: int = MODEL_RATE):
        g = math.gcd(int(rate), target)
        self.read, self.n, self.rate, self.target = read, n, int(rate), target
        self.down, self.up = int(rate) // g, target // g     # 441 input samples -> 160 output samples
        self.step = self.down * max(1, _BLOCK // self.down)
        self.margin = self.down * -(-_MARGIN // self.down)
        self.n_out = int(round(n * target / rate))
        self.per_block = self.step // self.down * self.up
        self.n_blocks = -(-n // self.step)

    def span(self, j: int) -> tuple[int, int]:
        """The input samples a..b block ``j`` is computed from."""
        start = j * self.step
        return max(0, start - self.margin), min(self.n, start + self.step + self.margin)

    def block(self, j: int) -> np.ndarray:
        a, b = self.span(j)
        return self.block_from(j, self.read(a, b), self.n_out)

    def block_from(self, j: int, x: np.ndarray, n_out: int | None = None) -> np.ndarray:
        """Block ``j`` from the input samples of :meth:`span` (float64), cut
        at ``n_out`` output samples in all (None: a whole block)."""
        start = j * self.step
        a = max(0, start - self.margin)
        y = _resample_whole(x, self.rate, self.target)
        o0 = start // self.down * self.up
        take = self.per_block if n_out is None else min(self.per_block, n_out - o0)
        off = (start - a) // self.down * self.up
        return y[off:off + take].astype(np.float32)


class StreamResampler:
    """:func:`resample` of a signal at an integer rate that arrives in pieces
    (a decoder's blocks) whose total is known only at the end: :meth:`push`
    each piece and take the output ready so far, then :meth:`finish` for the
    rest.  Only a block and its margins are held.  The output is that of
    :func:`resample` for signals of more than two blocks (shorter ones are
    resampled whole there)."""

    def __init__(self, rate: int, target: int = MODEL_RATE):
        self.rate, self.target = int(rate), target
        self._blocks = BlockResampler(None, 0, rate, target)
        self._pending: list[np.ndarray] = []
        self._held = 0          # samples in _pending
        self._first = 0         # input index of _pending's first sample
        self._j = 0             # next output block

    def _input(self, a: int, b: int) -> np.ndarray:
        if len(self._pending) > 1:
            self._pending = [np.concatenate(self._pending)]
        return self._pending[0][a - self._first:b - self._first].astype(np.float64)

    def push(self, x: np.ndarray) -> np.ndarray:
        """Add the next input samples; return the output now complete."""
        x = np.asarray(x, np.float32)
        if self.rate == self.target:
            return x
        if len(x):
            self._pending.append(x)
            self._held += len(x)
        blocks, out = self._blocks, []
        while (self._j + 1) * blocks.step + blocks.margin <= self._first + self._held:
            start = self._j * blocks.step
            out.append(blocks.block_from(self._j, self._input(max(0, start - blocks.margin),
                                                              start + blocks.step + blocks.margin)))
            self._j += 1
            keep = self._j * blocks.step - blocks.margin - self._first    # the next block's margin on
            self._pending = [self._pending[0][keep:]]
            self._first += keep
            self._held -= keep
        return np.concatenate(out) if out else np.zeros(0, np.float32)

    def finish(self) -> np.ndarray:
        """The rest of the output, now that the input has ended."""
        if self.rate == self.target:
            return np.zeros(0, np.float32)
        n = self._first + self._held
        blocks = BlockResampler(None, n, self.rate, self.target)
        out = []
        for j in range(self._j, blocks.n_blocks):
            a, b = blocks.span(j)
            out.append(blocks.block_from(j, self._input(a, b), blocks.n_out))
        self._j = blocks.n_blocks
        return np.concatenate(out) if out else np.zeros(0, np.float32)
