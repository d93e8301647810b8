/* A run's log read once for the per-run report (analysis/report_series.py,
 * through ctypes): the card's and the truth's figures per block, and each
 * particle's card-minus-truth difference with its running figures, decoded
 * in C++ with the generated types (from lcmtypes/) and made whole by
 * ObjectsView (objects_view.hpp), the one reader of objects messages. The
 * reading goes in chunks and the particles' differences are decimated
 * here, so the caller holds at most a chunk at a time and the rows it is
 * handed are bounded whatever the log's length (a drifting sample moves
 * every particle every block: a row per particle per block, read here and
 * not handed on).
 *
 * Rows are doubles (seq and times are integers well within 2^53), their
 * columns named by afm_log_series_columns:
 *   blocks     FW_STATE and SIM_TRUTH, the first message of each block
 *              (seq) of each channel in log order (a fix's answer repeats
 *              its block's figures): channel (0 FW_STATE, 1 SIM_TRUTH),
 *              seq, utime_us, force_nN_x/y/z, tip_nm_x/y/z.
 *   diffs      a particle's card-minus-truth difference: id, utime_us,
 *              x_nm, y_nm (the difference's x and y). A difference starts at a set (FW_STATE's or
 *              SIM_TRUTH's objects, at the set's utime) that places the
 *              particle where that side did not have it, once both sides
 *              have it: the card's last position less the truth's last
 *              one; it holds until the particle's next difference (the
 *              end: the last message's utime). With bin_us > 0 only each
 *              time bin's extremes are handed on: per particle and bin
 *              [k bin_us, (k+1) bin_us) the rows of least and greatest x
 *              and y (at most 4, in time order); with bin_us a power of two
 *              no greater than the caller's own bins, a line through the
 *              bins' extremes is the line through every difference's.
 *   stats      per particle with a difference, over every difference (not
 *              only those handed on), each weighted by the time it held:
 *              id, n (differences), w (us held), sum_x, sum_y (of w d),
 *              sq_x, sq_y (of w d^2), worst_x, worst_y (largest |d|).
 *
 * Built as build/main/bus/libafm_log_series_c.so. No C++ exception leaves
 * these functions. */
#ifndef AFM_LOG_SERIES_C_H
#define AFM_LOG_SERIES_C_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The columns of a kind of row ("blocks", "diffs" or "stats"),
 * comma-separated; NULL for another kind. */
const char *afm_log_series_columns(const char *kind);

/* A reader of the log at `path` (opened here: a /proc/self/fd/N path of a
 * file the caller opened is read as that file), the particles' differences
 * decimated into bins of bin_us microseconds (0: every difference handed
 * on); NULL, with the reason in err (a one-line message naming the file),
 * when it cannot be opened. */
void *afm_log_series_open(const char *path, double bin_us, char *err, size_t err_len);
void afm_log_series_free(void *reader);

/* Reads on until `cap` block rows are in `rows` (cap times the blocks'
 * columns), the differences waiting to be taken reach
 * AFM_LOG_SERIES_MAX_WAITING, or the log ends: the rows written (0 at the
 * end, or when differences wait), -1 when the log does not read whole
 * (truncated, corrupt: the reason in err, naming the file and the byte
 * offset). At the end the differences still holding are closed and every
 * bin let out. */
long afm_log_series_blocks(void *reader, double *rows, long cap, char *err, size_t err_len);
#define AFM_LOG_SERIES_MAX_WAITING 65536

/* The diff rows made so far, at most `cap` into `rows` (cap times the
 * diffs' columns): the rows written, 0 when none is left. */
long afm_log_series_diffs(void *reader, double *rows, long cap);

/* The stats rows, one per particle with a difference, in id order, at most
 * `cap` into `rows`: the rows written. Whole once the log has ended. */
long afm_log_series_stats(void *reader, double *rows, long cap);

/* Messages on FW_STATE or SIM_TRUTH that did not decode as their type
 * (left out), and objects messages ObjectsView refused, so far. */
long afm_log_series_undecodable(void *reader);
/* The recording time (the log's timestamp, us since the epoch) of the
 * first (which 0) and the last (1) FW_STATE or SIM_TRUTH event read so
 * far; 0 before any. */
long long afm_log_series_recorded(void *reader, int which);
long afm_log_series_refused(void *reader);

#ifdef __cplusplus
}
#endif

#endif
