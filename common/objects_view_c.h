/* ObjectsView (objects_view.hpp), the one reader of objects messages, for
 * callers that are not C++: the Python log reader (tools/afmlog.py, through
 * ctypes) reads a log's objects as the bus's processes read them, rather
 * than by a rule of its own.
 *
 * Messages go in and out LCM-encoded (afm.objects_t, with its fingerprint),
 * as on the bus and in a log. Built as build/main/common/
 * libafm_objects_view_c.so. */
#ifndef AFM_OBJECTS_VIEW_C_H
#define AFM_OBJECTS_VIEW_C_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Told of each message placed in the set: its block and fix (seq,
 * fix_id), and the whole set after it, encoded (len bytes, valid during
 * the call only). */
typedef void (*afm_objects_placed_fn)(void *ctx, int64_t seq, int32_t fix_id, const uint8_t *whole, size_t len);

/* A reader with nothing read yet; NULL if out of memory. */
void *afm_objects_view_new(void);
void afm_objects_view_free(void *view);

/* Reads one encoded objects_t message. Returns 0 applied (the set now
 * includes it, or a later one: a resend, an old message), 1 held (kept for
 * its base), 2 refused (ObjectsView::Take), or -1 if the bytes do not
 * decode as objects_t (the view is unchanged) or the set cannot be handed
 * to `placed` (out of memory: the view then holds the message, the caller
 * was not told). `placed` (may be NULL) is called for the message if it is
 * placed, then for each held message it lets follow, in turn. No C++
 * exception leaves these functions. */
int afm_objects_view_apply(void *view, const uint8_t *data, size_t len, afm_objects_placed_fn placed, void *ctx);

#ifdef __cplusplus
}
#endif

#endif
