"""The report's decoded state stays bounded whatever the run's length
(analysis/report_series.py, Envelope): a synthetic run of 10^7 blocks (a
4-hour run at the 1 kHz default, in chunks as the log's reader hands them)
keeps at most `bins` bins a series, and the same bytes as a run of 10^5;
its extremes are exact and each bin's extremes keep their times; a short
run (at most two rows a bin) is kept row for row. Needs no build."""
import numpy as np

from analysis.report_series import Envelope

CHUNK = 16384


def feed(env, n_rows, step_us=1000.0, seed=1):
    """n_rows rows of series 0 and 1 (alternate), in chunks; their true extremes."""
    rng = np.random.default_rng(seed)
    lo, hi, peak_t = np.inf, -np.inf, None
    for start in range(0, n_rows, CHUNK):
        k = np.arange(start, min(n_rows, start + CHUNK))
        t = k * step_us
        v = np.stack([np.sin(k * 1e-4) + 0.01 * rng.standard_normal(len(k)), k * 1e-6], 1)
        env.add(k % 2, t, v)
        i = int(np.argmax(v[:, 0]))
        if v[i, 0] > hi:
            hi, peak_t = v[i, 0], t[i]
        lo = min(lo, v[:, 0].min())
    return lo, hi, peak_t


def test_state_is_bounded_whatever_the_length():
    short, long = Envelope(["a", "b"], 1024), Envelope(["a", "b"], 1024)
    feed(short, 100_000)
    lo, hi, peak_t = feed(long, 10_000_000)
    assert long.nbytes() == short.nbytes() <= 2 * 2 * 1024 * 4 * 8
    for s in (0, 1):
        t, v = long.points(s, "a")
        assert len(t) <= 2 * 1024 and np.all(np.diff(t) >= 0)
    both = [long.extent(s, "a") for s in (0, 1)]
    assert min(b[0] for b in both) == lo and max(b[1] for b in both) == hi
    s = 0 if both[0][1] == hi else 1
    t, v = long.points(s, "a")
    assert t[np.argmax(v)] == peak_t * 1e-6, "the peak keeps its time"


def test_a_short_run_is_kept_row_for_row():
    env = Envelope(["a"], 4096)
    t = np.arange(3000) * 1000.0
    v = np.cos(np.arange(3000) * 0.01)[:, None]
    for start in range(0, 3000, 700):
        env.add(np.zeros(len(t[start:start + 700]), dtype=np.int64), t[start:start + 700], v[start:start + 700])
    pt, pv = env.points(0, "a")
    assert np.array_equal(pt, t * 1e-6) and np.array_equal(pv, v[:, 0])


def test_series_grow_as_they_come():
    env = Envelope(["x"], 64)
    env.add(np.array([0, 5]), np.array([10.0, 20.0]), np.array([[1.0], [2.0]]))
    assert env.n == 6
    assert env.points(5, "x")[1].tolist() == [2.0]
    assert env.points(3, "x")[0].size == 0


def test_card_minus_truth_pairs_blocks_across_chunks():
    """FW and TRUTH rows of a block meet though they come in different
    chunks (the card's a block late); the bias and RMS are the pairs'."""
    from analysis.report_series import BLOCK_COLUMNS, FW, TRUTH, Stats, _BlockPairs
    pairs, stats = _BlockPairs(), Stats(BLOCK_COLUMNS)
    n, k = 1000, len(BLOCK_COLUMNS)
    truth = np.column_stack([np.full(n, TRUTH), np.arange(n), np.arange(n) * 1000.0, np.zeros((n, k))])
    card = truth.copy()
    card[:, 0], card[:, 3] = FW, 0.06 + 0.1 * np.where(np.arange(n) % 2, 1, -1)   # F_x: bias 0.06, RMS sqrt(0.06² + 0.1²)
    order = [truth[0]] + [r for i in range(1, n) for r in (truth[i], card[i - 1])] + [card[n - 1]]
    rows = np.array(order)   # the card's row of block i after the truth's of i + 1, as a log has them
    got = 0
    for start in range(0, 2 * n, 333):
        chunk = rows[start:start + 333]
        t, d = pairs.pair(chunk[:, 0].astype(np.int64), chunk)
        stats.add(d)
        got += len(t)
    assert got == n
    f = stats.figures("force_nN_x")
    assert abs(f["bias"] - 0.06) < 1e-12 and abs(f["rms"] - np.hypot(0.06, 0.1)) < 1e-12 and f["n"] == n
    assert max(len(h) for h in pairs.held) == 0, "nothing left waiting"
