/* A run's log read once for the per-run report (analysis/report_series.py,
 * through ctypes): the card's and the truth's figures per block, and the
 * particles as each side holds them, decoded in C++ with the generated
 * types (from lcmtypes/) and made whole by ObjectsView (objects_view.hpp),
 * the one reader of objects messages. The reading goes in chunks, so the
 * caller holds at most a chunk at a time, whatever the log's length.
 *
 * Rows are doubles (seq and times are integers well within 2^53), their
 * columns named by afm_log_series_columns:
 *   blocks     FW_STATE and SIM_TRUTH, the first message of each block
 *              (seq) of each channel in log order (a fix's answer repeats
 *              its block's figures): channel (0 FW_STATE, 1 SIM_TRUTH),
 *              seq, utime_us, force_nN_x/y/z, tip_nm_x/y/z.
 *   particles  each particle of the whole set after each message placed
 *              (FW_STATE's and SIM_TRUTH's objects): channel, seq, fix_id,
 *              utime_us (the set's), id, x_nm, y_nm; only the rows where a
 *              particle's position changes, each with the row before it
 *              (and every particle's first and last row): a line through
 *              them is the line through every row, as are its extremes.
 *
 * Built as build/main/bus/libafm_log_series_c.so. No C++ exception leaves
 * these functions. */
#ifndef AFM_LOG_SERIES_C_H
#define AFM_LOG_SERIES_C_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The columns of a kind of row ("blocks" or "particles"), comma-separated;
 * NULL for another kind. */
const char *afm_log_series_columns(const char *kind);

/* A reader of the log at `path` (opened here: a /proc/self/fd/N path of a
 * file the caller opened is read as that file); NULL, with the reason in
 * err (a one-line message naming the file), when it cannot be opened. */
void *afm_log_series_open(const char *path, char *err, size_t err_len);
void afm_log_series_free(void *reader);

/* Reads on until `cap` block rows are in `rows` (cap times the blocks'
 * columns) or the log ends: the rows written, 0 at the end, -1 when the log
 * does not read whole (truncated, corrupt: the reason in err, naming the
 * file and the byte offset). At the end the particles' held last rows are
 * let out. */
long afm_log_series_blocks(void *reader, double *rows, long cap, char *err, size_t err_len);

/* The particle rows the blocks read so far made, at most `cap` into
 * `rows` (cap times the particles' columns): the rows written, 0 when none
 * is left. */
long afm_log_series_particles(void *reader, double *rows, long cap);

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
