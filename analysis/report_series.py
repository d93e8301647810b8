"""What the per-run report plots, read from a run's bus.lcmlog in one
streaming pass, in memory bounded whatever the run's length.

    series = report_series.read("/proc/self/fd/N")   # or a path
    t, v = series.blocks.points(series.FW, "force_nN_x")
    series.particle_ids(), series.particle_span(i), series.particle_points(ch, i, "x_nm")

The log is read by bus/log_series_c.h (through ctypes): the one C++ pass
that frames the events (LogReader), decodes FW_STATE and SIM_TRUTH with the
generated types and makes their objects whole with ObjectsView; its rows
(columns named by the library) come in chunks of CHUNK_ROWS and go into
Envelopes here, never kept whole:

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
  blocks     channel FW (the card, FW_STATE) and TRUTH (SIM_TRUTH): the
             first message of each block; columns force_nN_x/y/z, tip_nm_x/y.
  particles  (channel, particle id): x_nm, y_nm of the whole sets placed.
  diff       card minus truth per block, the two channels' rows paired by
             the block's seq (a row waits for its partner across chunks; one
             whose partner's channel has gone past it is dropped):
             force_nN_x/y/z, tip_nm_x/y; diff_stats its Stats.
  particle_diff  card minus truth per particle (series: particle_diff_ids),
             x_nm, y_nm: at each particle row, that side's position less
             the other side's last one (the rows come only where a position
             changes, so the last one holds until the next); its Stats per
             particle weighted by the time each difference held.

Raises LogError (the file and the byte offset) for a log that does not read
whole, and FileNotFoundError when the library is not built."""
import ctypes
import os

import numpy as np

from analysis import paths

FW, TRUTH = 0, 1
CHUNK_ROWS = 16384
BLOCK_BINS = 4096       # the force and apex figures: about 800 px of axes each
PARTICLE_BINS = 1024    # the objects' figure: two axes of about 400 px
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
        key = series.astype(np.int64) * self.bins + (t // self.width).astype(np.int64)
        for c in range(len(self.columns)):
            v = values[:, c]
            order = np.lexsort((v, key))
            ks = key[order]
            starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
            ends = np.r_[starts[1:] - 1, len(ks) - 1]
            keys = ks[starts]
            s, b = keys // self.bins, keys % self.bins
            for vals, times, at, better in ((self.lo, self.tlo, starts, np.less), (self.hi, self.thi, ends, np.greater)):
                v_new, t_new = v[order[at]], t[order[at]]
                take = better(v_new, vals[s, c, b])
                vals[s[take], c, b[take]] = v_new[take]
                times[s[take], c, b[take]] = t_new[take]

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


class _ParticlePairs:
    """Card minus truth per particle, the other side's last position held (Series.particle_diff)."""

    def __init__(self):
        self.last = {}    # (channel, id) -> (x, y)
        self.prev = {}    # id -> (time covered up to, dx, dy): the last difference, still holding

    def pair(self, rows, col):
        """Particle rows in log order -> (ids, t, d, weights of the previous differences)."""
        out_id, out_t, out_d, done = [], [], [], []   # done: (id, d, weight) of differences that ended
        ch, pid = rows[:, col["channel"]].astype(int), rows[:, col["id"]].astype(int)
        t, xy = rows[:, col["utime_us"]], rows[:, [col["x_nm"], col["y_nm"]]]
        for i in range(len(rows)):
            c, p = ch[i], pid[i]
            self.last[(c, p)] = (xy[i, 0], xy[i, 1])
            other = self.last.get((1 - c, p))
            if other is None:
                continue
            card, truth = (self.last[(FW, p)], self.last[(TRUTH, p)])
            d = (card[0] - truth[0], card[1] - truth[1])
            covered = t[i]
            if p in self.prev:   # the previous difference held from the time covered so far to this row's
                pt, px, py = self.prev[p]
                done.append((p, px, py, max(0.0, t[i] - pt)))
                covered = max(pt, t[i])
            self.prev[p] = (covered, d[0], d[1])
            out_id.append(p)
            out_t.append(t[i])
            out_d.append(d)
        return out_id, out_t, out_d, done

    def close(self, t_end):
        """The differences still holding, each until t_end."""
        return [(p, px, py, max(0.0, t_end - pt)) for p, (pt, px, py) in self.prev.items()]


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
        lib.afm_log_series_open.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_size_t]
        lib.afm_log_series_free.argtypes = [ctypes.c_void_p]
        dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
        lib.afm_log_series_blocks.restype = ctypes.c_long
        lib.afm_log_series_blocks.argtypes = [ctypes.c_void_p, dbl, ctypes.c_long, ctypes.c_char_p, ctypes.c_size_t]
        lib.afm_log_series_particles.restype = ctypes.c_long
        lib.afm_log_series_particles.argtypes = [ctypes.c_void_p, dbl, ctypes.c_long]
        for f in (lib.afm_log_series_undecodable, lib.afm_log_series_refused):
            f.restype, f.argtypes = ctypes.c_long, [ctypes.c_void_p]
        lib.afm_log_series_recorded.restype = ctypes.c_longlong
        lib.afm_log_series_recorded.argtypes = [ctypes.c_void_p, ctypes.c_int]
        _LIB = lib
    return _LIB


def _columns(kind):
    return _lib().afm_log_series_columns(kind.encode()).decode().split(",")


class Series:
    """The report's decoded state (module docstring): two Envelopes and the
    particle ids met, in order; bounded by the bins and the scene's objects."""

    def __init__(self):
        self.blocks = Envelope(BLOCK_COLUMNS, BLOCK_BINS)
        self.particles = Envelope(PARTICLE_COLUMNS, PARTICLE_BINS)
        self.ids = {}             # (channel, particle id) -> series index in self.particles
        self.block_rows = [0, 0]  # rows per channel (FW, TRUTH)
        self.undecodable = self.refused = 0
        self.recorded = (0, 0)    # the first and last block's recording time, us since the epoch
        self.diff = Envelope(BLOCK_COLUMNS, DIFF_BINS)
        self.diff_stats = Stats(BLOCK_COLUMNS)
        self.particle_diff = Envelope(PARTICLE_COLUMNS, DIFF_BINS)
        self.particle_diff_stats = {}   # particle id -> Stats
        self.diff_index = {}            # particle id -> series index in particle_diff
        self._pairs, self._ppairs, self._t_end = _BlockPairs(), _ParticlePairs(), 0.0

    def has(self, channel):
        return self.block_rows[channel] > 0

    def particle_ids(self, channel):
        return sorted(i for ch, i in self.ids if ch == channel)

    def particle_span(self, channel, pid):
        """How far a particle went: its x extent plus its y extent, nm."""
        s = self.ids[(channel, pid)]
        return sum(hi - lo for lo, hi in (self.particles.extent(s, c) for c in PARTICLE_COLUMNS))

    def particle_points(self, channel, pid, column):
        s = self.ids.get((channel, pid))
        return (np.array([]), np.array([])) if s is None else self.particles.points(s, column)

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
        self.blocks.add(ch, rows[:, col["utime_us"]], values)
        if len(rows):
            self._t_end = max(self._t_end, float(rows[:, col["utime_us"]].max()))
        t, d = self._pairs.pair(ch, np.column_stack([ch, rows[:, col["seq"]], rows[:, col["utime_us"]], values]))
        self.diff.add(np.zeros(len(t), dtype=np.int64), t, d)
        self.diff_stats.add(d)

    def _diff_stats(self, done):
        if not done:
            return
        a = np.array(done, dtype=float)
        for p in np.unique(a[:, 0]).astype(int).tolist():
            mine = a[a[:, 0] == p]
            self.particle_diff_stats.setdefault(p, Stats(PARTICLE_COLUMNS)).add(mine[:, 1:3], mine[:, 3])

    def _finish(self):
        self._diff_stats(self._ppairs.close(self._t_end))

    def _add_particles(self, rows, col):
        keys = zip(rows[:, col["channel"]].astype(int).tolist(), rows[:, col["id"]].astype(int).tolist())
        index = np.array([self.ids.setdefault(k, len(self.ids)) for k in keys], dtype=np.int64)
        self.particles.add(index, rows[:, col["utime_us"]], rows[:, [col[c] for c in PARTICLE_COLUMNS]])
        ids, t, d, done = self._ppairs.pair(rows, col)
        if ids:
            index = np.array([self.diff_index.setdefault(p, len(self.diff_index)) for p in ids], dtype=np.int64)
            self.particle_diff.add(index, np.array(t), np.array(d))
        self._diff_stats(done)


def read(path, chunk_rows=CHUNK_ROWS):
    """The Series of the log at `path`, in one pass (module docstring)."""
    lib = _lib()
    bcols, pcols = _columns("blocks"), _columns("particles")
    bcol, pcol = {c: i for i, c in enumerate(bcols)}, {c: i for i, c in enumerate(pcols)}
    err = ctypes.create_string_buffer(512)
    reader = lib.afm_log_series_open(os.fsencode(path), err, len(err))
    if not reader:
        raise FileNotFoundError(err.value.decode(errors="replace"))
    out = Series()
    brows, prows = np.empty((chunk_rows, len(bcols))), np.empty((chunk_rows, len(pcols)))
    try:
        while True:
            n = lib.afm_log_series_blocks(reader, brows, chunk_rows, err, len(err))
            if n < 0:
                raise LogError(err.value.decode(errors="replace"))
            out._add_blocks(brows[:n], bcol)
            while (m := lib.afm_log_series_particles(reader, prows, chunk_rows)) > 0:
                out._add_particles(prows[:m], pcol)
            if n == 0:
                break
        out.undecodable, out.refused = lib.afm_log_series_undecodable(reader), lib.afm_log_series_refused(reader)
        out.recorded = (lib.afm_log_series_recorded(reader, 0), lib.afm_log_series_recorded(reader, 1))
        out._finish()
    finally:
        lib.afm_log_series_free(reader)
    return out
