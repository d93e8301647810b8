"""What the per-run report plots, read from a run's bus.lcmlog in one
streaming pass, in time and memory bounded whatever the run's length.

    series = report_series.read("/proc/self/fd/N", duration_s)   # or a path
    t, v = series.diff.points(0, "force_nN_x")
    series.diff_stats.figures("force_nN_x")          # bias, RMS, worst, n
    series.particle_diff_ids(), series.particle_diff_points(i, "x_nm")

The log is read by bus/log_series_c.h (through ctypes): the one C++ pass
that frames the events (LogReader), decodes FW_STATE and SIM_TRUTH with the
generated types and makes their objects whole with ObjectsView. Each
particle's card-minus-truth difference is made there, row by row, with its
running figures, and only each fine time bin's extremes are handed on
(fine_bin_us: with a drifting sample every particle moves every block, and
those rows never reach Python). The rows come in chunks of CHUNK_ROWS and go
into Envelopes here, never kept whole:

  Envelope   per series and column, at most `bins` time bins; in each bin
             the least and the greatest value with their times. A bin
             holding one or two rows keeps them exactly; a longer run's bins
             widen (doubling, neighbours merged) so that the whole run fits.
             points() is the line through each bin's extremes in time
             order: plotted over at most `bins` pixel columns it draws what
             the line through every row draws, extremes included.

  Stats      per column, over the rows added: their count, mean (the
             bias), RMS and the largest magnitude; rows may carry weights
             (a time each value held).

Series:
  block_rows FW_STATE's (FW) and SIM_TRUTH's (TRUTH) block rows read: the
             first message of each block.
  diff       card minus truth per block, the two channels' rows paired by
             the block's seq (a row waits for its partner across chunks; one
             whose partner's channel has gone past it is dropped):
             force_nN_x/y/z, tip_nm_x/y; diff_stats its Stats.
  particle_diff  card minus truth per particle (series: particle_diff_ids),
             x_nm, y_nm: from each set that moves the particle on either
             side, that side's position less the other side's last one,
             holding until the next (log_series_c.h, "diffs"); its Stats per
             particle (particle_diff_stats) over every difference, weighted
             by the time each held.

Raises LogError (the file and the byte offset) for a log that does not read
whole, and FileNotFoundError when the library is not built."""
import ctypes
import os

import numpy as np

from analysis import paths

FW, TRUTH = 0, 1
CHUNK_ROWS = 16384
DIFF_BINS = 1024        # card minus truth: a bin to a pixel column or so (a noisy line drawn no longer than it shows)
BLOCK_COLUMNS = ["force_nN_x", "force_nN_y", "force_nN_z", "tip_nm_x", "tip_nm_y"]
PARTICLE_COLUMNS = ["x_nm", "y_nm"]


class LogError(ValueError):
    """A log that does not read whole (its message names the file and the offset)."""


class Envelope:
    """Streaming min/max decimation of `columns` for series 0..n-1 over time
    (microseconds from 0), at most `bins` bins a series (module docstring)."""

    def __init__(self, columns, bins):
        self.columns, self.bins, self.width = list(columns), bins, 1.0
        self.n, self.any = 0, False
        shape = (0, len(self.columns), bins)
        self.lo, self.hi = np.full(shape, np.inf), np.full(shape, -np.inf)
        self.tlo, self.thi = np.zeros(shape), np.zeros(shape)

    def _grow(self, n):
        extra = n - self.lo.shape[0]
        if extra <= 0:
            return
        extra = max(extra, self.lo.shape[0])   # doubling: amortised
        pad = ((0, extra), (0, 0), (0, 0))
        self.lo = np.pad(self.lo, pad, constant_values=np.inf)
        self.hi = np.pad(self.hi, pad, constant_values=-np.inf)
        self.tlo, self.thi = np.pad(self.tlo, pad), np.pad(self.thi, pad)

    def _coarsen(self):
        """Each pair of neighbouring bins merged into one, the width doubled."""
        s, c, b = self.lo.shape
        half = b // 2

        def merge(v, t, pick):
            v2, t2 = v.reshape(s, c, half, 2), t.reshape(s, c, half, 2)
            k = pick(v2, axis=3)[..., None]
            return np.take_along_axis(v2, k, 3)[..., 0], np.take_along_axis(t2, k, 3)[..., 0]

        lo, tlo = merge(self.lo, self.tlo, np.argmin)
        hi, thi = merge(self.hi, self.thi, np.argmax)
        fill = (s, c, b - half)
        self.lo, self.tlo = np.concatenate([lo, np.full(fill, np.inf)], 2), np.concatenate([tlo, np.zeros(fill)], 2)
        self.hi, self.thi = np.concatenate([hi, np.full(fill, -np.inf)], 2), np.concatenate([thi, np.zeros(fill)], 2)
        self.width *= 2

    def add(self, series, t, values):
        """Rows: series index (int array), time t (us), values (rows x columns)."""
        if len(t) == 0:
            return
        t = np.maximum(np.asarray(t, dtype=float), 0.0)
        self.n = max(self.n, int(series.max()) + 1)
        self._grow(self.n)
        if not self.any:   # nothing held yet: the width the rows need, at once
            self.width = float(2 ** max(0, int(np.ceil(np.log2((t.max() + 1) / self.bins)))))
        self.any = True
        while t.max() >= self.bins * self.width:
            self._coarsen()
        # each row's bin in the flat (series, column, bin) arrays, folded in
        # by ufunc.at; a bin's extreme keeps the time of its row (among equal
        # values: the least's first, the greatest's last, in the rows' order)
        k = len(self.columns)
        at = series.astype(np.int64) * k * self.bins + (t // self.width).astype(np.int64)
        for c in range(k):
            v, idx = values[:, c], at + c * self.bins
            for vals, times, fold, better, first in ((self.lo, self.tlo, np.fmin, np.less, True),
                                                    (self.hi, self.thi, np.fmax, np.greater, False)):
                flat, tflat = vals.reshape(-1), times.reshape(-1)   # views: the arrays are C-contiguous
                old = flat[idx]
                fold.at(flat, idx, v)
                hit = np.flatnonzero(better(v, old) & (v == flat[idx]))
                if first:
                    hit = hit[::-1]   # a repeated index takes the last value assigned
                tflat[idx[hit]] = t[hit]

    def points(self, series, column):
        """(t in s, values): the line through each bin's extremes, in time order."""
        if series >= self.n:
            return np.array([]), np.array([])
        c = self.columns.index(column)
        lo, hi, tlo, thi = self.lo[series, c], self.hi[series, c], self.tlo[series, c], self.thi[series, c]
        full = np.isfinite(lo)
        lo, hi, tlo, thi = lo[full], hi[full], tlo[full], thi[full]
        first = tlo <= thi
        t = np.stack([np.where(first, tlo, thi), np.where(first, thi, tlo)], 1)
        v = np.stack([np.where(first, lo, hi), np.where(first, hi, lo)], 1)
        keep = np.ones(t.shape, dtype=bool)
        keep[:, 1] = t[:, 1] != t[:, 0]   # one row in the bin: once
        return t[keep] * 1e-6, v[keep]

    def extent(self, series, column):
        """(least, greatest) of a column over every row of a series."""
        c = self.columns.index(column)
        return float(self.lo[series, c].min()), float(self.hi[series, c].max())

    def nbytes(self):
        return self.lo.nbytes + self.hi.nbytes + self.tlo.nbytes + self.thi.nbytes


class Stats:
    """Count, mean, RMS and largest magnitude per column over (weighted) rows."""

    def __init__(self, columns):
        self.columns = list(columns)
        k = len(self.columns)
        self.n, self.w = 0, 0.0
        self.sum, self.sq, self.worst = np.zeros(k), np.zeros(k), np.zeros(k)

    def add(self, values, weights=None):
        if len(values) == 0:
            return
        w = np.ones(len(values)) if weights is None else np.asarray(weights, dtype=float)
        self.n += len(values)
        self.w += float(w.sum())
        self.sum += w @ values
        self.sq += w @ (values * values)
        self.worst = np.maximum(self.worst, np.abs(values).max(0))

    def set_sums(self, n, w, sums, squares, worst):
        """The figures as the log's reader kept them (log_series_c.h, "stats")."""
        self.n, self.w = int(n), float(w)
        self.sum, self.sq, self.worst = np.asarray(sums, float), np.asarray(squares, float), np.asarray(worst, float)
        return self

    def figures(self, column):
        """{"bias", "rms", "worst", "n"} of a column (None for the first three without rows)."""
        c = self.columns.index(column)
        if self.w <= 0:
            return {"bias": None, "rms": None, "worst": None, "n": self.n}
        return {"bias": self.sum[c] / self.w, "rms": float(np.sqrt(self.sq[c] / self.w)), "worst": float(self.worst[c]),
                "n": self.n}


class _BlockPairs:
    """FW and TRUTH block rows paired by seq across chunks (Series.diff)."""

    def __init__(self):
        self.held = [np.empty((0, 2 + len(BLOCK_COLUMNS))), np.empty((0, 2 + len(BLOCK_COLUMNS)))]
        self.top = [-1.0, -1.0]   # the greatest seq met per channel

    def pair(self, ch, rows):
        """rows: seq, utime_us, BLOCK_COLUMNS...; returns (utime_us, card - truth) of the pairs made."""
        seq_t = [np.vstack([self.held[c], rows[ch == c][:, 1:]]) for c in (FW, TRUTH)]
        for c in (FW, TRUTH):
            if len(seq_t[c]):
                self.top[c] = max(self.top[c], float(seq_t[c][:, 0].max()))
        common, i_fw, i_tr = np.intersect1d(seq_t[FW][:, 0], seq_t[TRUTH][:, 0], assume_unique=False, return_indices=True)
        fw, tr = seq_t[FW][i_fw], seq_t[TRUTH][i_tr]
        for c in (FW, TRUTH):
            keep = np.ones(len(seq_t[c]), dtype=bool)
            keep[i_fw if c == FW else i_tr] = False
            left = seq_t[c][keep]
            self.held[c] = left[left[:, 0] > self.top[1 - c]]   # its partner can still come
        return tr[:, 1], fw[:, 2:] - tr[:, 2:]


_LIB = None


def _lib():
    global _LIB
    if _LIB is None:
        if not os.path.exists(paths.LOG_SERIES_LIB):
            raise FileNotFoundError(f"report_series: {paths.LOG_SERIES_LIB} is missing: build the bench first (./afm build)")
        lib = ctypes.CDLL(paths.LOG_SERIES_LIB)
        lib.afm_log_series_columns.restype = ctypes.c_char_p
        lib.afm_log_series_columns.argtypes = [ctypes.c_char_p]
        lib.afm_log_series_open.restype = ctypes.c_void_p
        lib.afm_log_series_open.argtypes = [ctypes.c_char_p, ctypes.c_double, ctypes.c_char_p, ctypes.c_size_t]
        lib.afm_log_series_free.argtypes = [ctypes.c_void_p]
        dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
        lib.afm_log_series_blocks.restype = ctypes.c_long
        lib.afm_log_series_blocks.argtypes = [ctypes.c_void_p, dbl, ctypes.c_long, ctypes.c_char_p, ctypes.c_size_t]
        for f in (lib.afm_log_series_diffs, lib.afm_log_series_stats):
            f.restype, f.argtypes = ctypes.c_long, [ctypes.c_void_p, dbl, ctypes.c_long]
        for f in (lib.afm_log_series_undecodable, lib.afm_log_series_refused):
            f.restype, f.argtypes = ctypes.c_long, [ctypes.c_void_p]
        lib.afm_log_series_recorded.restype = ctypes.c_longlong
        lib.afm_log_series_recorded.argtypes = [ctypes.c_void_p, ctypes.c_int]
        _LIB = lib
    return _LIB


def _columns(kind):
    return _lib().afm_log_series_columns(kind.encode()).decode().split(",")


def fine_bin_us(duration_s, bins=DIFF_BINS):
    """The log's reader's bins for a run of duration_s simulated seconds
    (its run.json sim_seconds, the last block's time): the greatest power
    of two (us) no greater than the run over `bins`, so that each of an
    Envelope's final bins (the least power of two over it) spans whole
    ones; 0 (every difference handed on) without a duration."""
    if not duration_s or not np.isfinite(duration_s) or duration_s <= 0:
        return 0.0
    return float(2 ** max(0, int(np.floor(np.log2(max(1.0, duration_s * 1e6 / bins))))))


class Series:
    """The report's decoded state (module docstring): its Envelopes and
    Stats, bounded by the bins and the scene's objects."""

    def __init__(self, bins=DIFF_BINS):
        self.block_rows = [0, 0]  # rows per channel (FW, TRUTH)
        self.diff_rows = 0        # particle difference rows the log's reader handed on
        self.undecodable = self.refused = 0
        self.recorded = (0, 0)    # the first and last block's recording time, us since the epoch
        self.diff = Envelope(BLOCK_COLUMNS, bins)
        self.diff_stats = Stats(BLOCK_COLUMNS)
        self.particle_diff = Envelope(PARTICLE_COLUMNS, bins)
        self.particle_diff_stats = {}   # particle id -> Stats
        self.diff_index = {}            # particle id -> series index in particle_diff
        self._pairs = _BlockPairs()

    def has(self, channel):
        return self.block_rows[channel] > 0

    def particle_diff_ids(self):
        return sorted(self.diff_index)

    def particle_diff_points(self, pid, column):
        s = self.diff_index.get(pid)
        return (np.array([]), np.array([])) if s is None else self.particle_diff.points(s, column)

    def _add_blocks(self, rows, col):
        ch = rows[:, col["channel"]].astype(np.int64)
        for c in (FW, TRUTH):
            self.block_rows[c] += int(np.count_nonzero(ch == c))
        values = rows[:, [col[c] for c in BLOCK_COLUMNS]]
        t, d = self._pairs.pair(ch, np.column_stack([ch, rows[:, col["seq"]], rows[:, col["utime_us"]], values]))
        self.diff.add(np.zeros(len(t), dtype=np.int64), t, d)
        self.diff_stats.add(d)

    def _add_diffs(self, rows, col):
        self.diff_rows += len(rows)
        ids, inverse = np.unique(rows[:, col["id"]].astype(np.int64), return_inverse=True)
        index = np.array([self.diff_index.setdefault(p, len(self.diff_index)) for p in ids.tolist()], dtype=np.int64)
        self.particle_diff.add(index[inverse], rows[:, col["utime_us"]], rows[:, [col[c] for c in PARTICLE_COLUMNS]])

    def _set_stats(self, rows, col):
        for r in rows:
            self.particle_diff_stats[int(r[col["id"]])] = Stats(PARTICLE_COLUMNS).set_sums(
                r[col["n"]], r[col["w"]], r[[col["sum_x"], col["sum_y"]]], r[[col["sq_x"], col["sq_y"]]],
                r[[col["worst_x"], col["worst_y"]]])


def read(path, duration_s=None, bins=DIFF_BINS, chunk_rows=CHUNK_ROWS):
    """The Series of the log at `path`, in one pass (module docstring);
    duration_s: the run's simulated seconds, if known (fine_bin_us); bins:
    the Envelopes' bins."""
    lib = _lib()
    bcol, dcol, scol = ({c: i for i, c in enumerate(_columns(k))} for k in ("blocks", "diffs", "stats"))
    err = ctypes.create_string_buffer(512)
    reader = lib.afm_log_series_open(os.fsencode(path), fine_bin_us(duration_s, bins), err, len(err))
    if not reader:
        raise FileNotFoundError(err.value.decode(errors="replace"))
    out = Series(bins)
    brows, drows = np.empty((chunk_rows, len(bcol))), np.empty((chunk_rows, len(dcol)))
    try:
        while True:
            n = lib.afm_log_series_blocks(reader, brows, chunk_rows, err, len(err))
            if n < 0:
                raise LogError(err.value.decode(errors="replace"))
            out._add_blocks(brows[:n], bcol)
            drained = 0
            while (m := lib.afm_log_series_diffs(reader, drows, chunk_rows)) > 0:
                out._add_diffs(drows[:m], dcol)
                drained += m
            if n == 0 and drained == 0:
                break
        stats = np.empty((max(1, len(out.diff_index)), len(scol)))
        out._set_stats(stats[:lib.afm_log_series_stats(reader, stats, len(stats))], scol)
        out.undecodable, out.refused = lib.afm_log_series_undecodable(reader), lib.afm_log_series_refused(reader)
        out.recorded = (lib.afm_log_series_recorded(reader, 0), lib.afm_log_series_recorded(reader, 1))
    finally:
        lib.afm_log_series_free(reader)
    return out
