/*
 * fw_marshal.h - the card's structs as bytes, for the link between the host
 * and the board that runs the card (processor in the loop, pil.md).
 *
 * Contract:
 *   - Every struct crosses field by field, each integer as 4 bytes little
 *     endian (int32_t two's complement, uint32_t), each bool as one byte 0
 *     or 1; never as raw memory (padding and bool differ between the host's
 *     and the board's ABI). The layout of each message is written down
 *     once, in fw_marshal.c, and only there.
 *   - A message is a header (fw_marshal_put_header_le: magic, kind, payload
 *     length) and its payload. The host sends INIT (the configuration and
 *     its storage's capacities), STEP (a block in) and FIX (a drift fix or a
 *     place fix); the board answers each with the same kind, its result,
 *     and the card's models after it (fw_models.h). STEP's answer carries
 *     the board's timer ticks around fw_card_step_block.
 *   - Writers never write past their buffer, readers never read past
 *     theirs: the first field that does not fit, or that holds a value the
 *     struct cannot (a bool not 0 or 1, a count below 0 or above the
 *     caller's capacity), makes the cursor bad; it keeps that field's name
 *     and value (fw_marshal_cursor_t.bad_field, bad_value) and every later
 *     put or get does nothing. A get into a bad cursor leaves its struct
 *     partly written: use it only when the cursor is good.
 *   - No heap; the caller owns every buffer and array. Scaling and
 *     overflow: none in this module: values are copied, never computed.
 */
#ifndef FW_MARSHAL_H
#define FW_MARSHAL_H

#include "fw_card.h"
#include "fw_models.h"

#define FW_MARSHAL_MAGIC 0x424D4641u   /* "AFMB" in little-endian bytes */
#define FW_MARSHAL_HEADER_BYTES 12u

typedef enum {
    FW_MARSHAL_INIT = 1,   /* host: configuration; board: the rule (FW_RULE_OK: running), models */
    FW_MARSHAL_STEP = 2,   /* host: fw_card_in_t; board: status, fw_card_out_t, step and board ticks, models */
    FW_MARSHAL_FIX = 3,    /* host: fix request; board: status, fw_card_fix_out_t, models */
    FW_MARSHAL_ERROR = 4   /* board: it could not take a request: a line of text */
} fw_marshal_kind_t;

/* A read or write position in a caller's buffer. */
typedef struct {
    uint8_t *w;            /* writing: the buffer (NULL when reading) */
    const uint8_t *r;      /* reading: the buffer (NULL when writing) */
    uint32_t len;          /* the buffer's size (writing) or the bytes there (reading) */
    uint32_t at;           /* bytes written or read so far */
    const char *bad_field; /* NULL while good; else the first field that failed */
    int32_t bad_value;     /* the value it held (a count, a bool's byte), or the bytes missing */
} fw_marshal_cursor_t;

void fw_marshal_writer_init(fw_marshal_cursor_t *cur, uint8_t *buf, uint32_t cap);
void fw_marshal_reader_init(fw_marshal_cursor_t *cur, const uint8_t *buf, uint32_t len);
bool fw_marshal_ok(const fw_marshal_cursor_t *cur);

/* The header; put_header writes payload_len as given (write the payload,
 * then fw_marshal_patch_len_le with the header's offset and its length). */
void fw_marshal_put_header_le(fw_marshal_cursor_t *cur, uint32_t kind, uint32_t payload_len);
void fw_marshal_get_header_le(fw_marshal_cursor_t *cur, uint32_t *kind, uint32_t *payload_len);   /* bad: magic */
void fw_marshal_patch_len_le(fw_marshal_cursor_t *cur, uint32_t header_at);

/* The arrays a received configuration points into (the receiver's). */
typedef struct {
    fw_card_particle_t *particles;
    int32_t particle_capacity;
    fw_card_wire_t *wires;
    int32_t wire_capacity;
    fw_card_landmark_t *landmarks;
    int32_t landmark_capacity;
} fw_marshal_config_arrays_t;

/* The card's configuration with its arrays inline, and the storage's
 * capacities for particles, wires and trench points (the card's behaviour
 * at a full trench store depends on it). get: the pointers of cfg point
 * into arr; the counts are checked against arr's capacities. */
void fw_marshal_put_config_le(fw_marshal_cursor_t *cur, const fw_card_config_t *cfg, const fw_card_storage_t *st);
void fw_marshal_get_config_le(fw_marshal_cursor_t *cur, fw_card_config_t *cfg, const fw_marshal_config_arrays_t *arr,
                              int32_t capacities[3]);

/* A block in: the pose, n, the n samples. get: the samples go to
 * samples[0, capacity); in->samples points there. */
void fw_marshal_put_in_le(fw_marshal_cursor_t *cur, const fw_card_in_t *in);
void fw_marshal_get_in_le(fw_marshal_cursor_t *cur, fw_card_in_t *in, fw_sample_in_t *samples, int32_t capacity);

/* A block's outputs (every field of fw_card_out_t). */
void fw_marshal_put_out_le(fw_marshal_cursor_t *cur, const fw_card_out_t *out);
void fw_marshal_get_out_le(fw_marshal_cursor_t *cur, fw_card_out_t *out);

/* A fix request: place (fw_card_place) or not (fw_card_fix), the object,
 * the scanned position. */
typedef struct {
    bool place;
    int32_t object_id;
    int32_t scan_pm[2];
} fw_marshal_fix_t;
void fw_marshal_put_fix_le(fw_marshal_cursor_t *cur, const fw_marshal_fix_t *fix);
void fw_marshal_get_fix_le(fw_marshal_cursor_t *cur, fw_marshal_fix_t *fix);
void fw_marshal_put_fix_out_le(fw_marshal_cursor_t *cur, const fw_card_fix_out_t *out);
void fw_marshal_get_fix_out_le(fw_marshal_cursor_t *cur, fw_card_fix_out_t *out);

/* The models (fw_models.h). put: the trench points from trench_from on
 * (the receiver keeps the earlier ones: the card only appends points
 * between two snapshots unless a fix moved them all or a reset cleared
 * them; then send from 0). get: particles and wires into m's storage
 * (capacities checked), the points sent into trench_store[from, ...)
 * (capacity checked), m->trench = trench_store. */
void fw_marshal_put_models_le(fw_marshal_cursor_t *cur, const fw_models_t *m, int32_t trench_from);
void fw_marshal_get_models_le(fw_marshal_cursor_t *cur, fw_models_t *m, fw_trench_point_t *trench_store,
                              int32_t trench_capacity);

/* Plain fields, for the messages' scalars (status, rule, ticks). */
void fw_marshal_put_i32_le(fw_marshal_cursor_t *cur, int32_t v);
void fw_marshal_put_u32_le(fw_marshal_cursor_t *cur, uint32_t v);
int32_t fw_marshal_get_i32_le(fw_marshal_cursor_t *cur, const char *field);
uint32_t fw_marshal_get_u32_le(fw_marshal_cursor_t *cur, const char *field);
/* Text (the board's ERROR): a length and its bytes; get copies at most
 * cap - 1 bytes and ends the text with 0. */
void fw_marshal_put_text_le(fw_marshal_cursor_t *cur, const char *text);
void fw_marshal_get_text_le(fw_marshal_cursor_t *cur, char *text, uint32_t cap);

#endif /* FW_MARSHAL_H */
