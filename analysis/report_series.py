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

Series:
  blocks     channel FW (the card, FW_STATE) and TRUTH (SIM_TRUTH): the
             first message of each block; columns force_nN_x/y/z, tip_nm_x/y.
  particles  (channel, particle id): x_nm, y_nm of the whole sets placed.

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

    def _add_blocks(self, rows, col):
        ch = rows[:, col["channel"]].astype(np.int64)
        for c in (FW, TRUTH):
            self.block_rows[c] += int(np.count_nonzero(ch == c))
        self.blocks.add(ch, rows[:, col["utime_us"]], rows[:, [col[c] for c in BLOCK_COLUMNS]])

    def _add_particles(self, rows, col):
        keys = zip(rows[:, col["channel"]].astype(int).tolist(), rows[:, col["id"]].astype(int).tolist())
        index = np.array([self.ids.setdefault(k, len(self.ids)) for k in keys], dtype=np.int64)
        self.particles.add(index, rows[:, col["utime_us"]], rows[:, [col[c] for c in PARTICLE_COLUMNS]])


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
    finally:
        lib.afm_log_series_free(reader)
    return out
