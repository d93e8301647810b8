/*
 * fw_marshal.c - the card's structs as bytes (fw_marshal.h). This file is
 * the one place the link's layout is written down; the host (card_node's
 * board backend) and the board (board/afm_board.c) both build it.
 *
 * Every int32_t and uint32_t: 4 bytes, little endian. Every bool: 1 byte,
 * 0 or 1. Arrays: their count first (int32), then the elements.
 *
 *   header     magic u32 ("AFMB"), kind u32 (fw_marshal_kind_t), payload bytes u32
 *   config     board: adc_bits, normal_gain_pn_per_v, lateral_gain_pn_per_v,
 *                deflection_pm_per_v, tip_height_nm, lever_length_nm,
 *                disp_n_pm_per_v, disp_l_pm_per_v, scan_angle_mdeg, mu_ppm,
 *                adhesion_pn, scan_center_pm[2], scan_half_range_pm, kappa_q16,
 *                filter_log2, theta_min_disp_pm;
 *              word_bits, tip_radius_pm, tip_half_angle_mdeg, down_force (bool);
 *              n_particles, each {id, x_pm, y_pm, radius_pm}; particle_mu_ppm,
 *                particle_adhesion_pn, particle_shear_kpa,
 *                particle_contact_area_nm2, particle_margin_pn;
 *              n_wires, each {id, a_pm[2], b_pm[2], diameter_pm};
 *                wire_friction_pn_per_um, wire_mu_ppm;
 *              litho (bool), litho_threshold_pn, litho_depth_pm_per_pn, litho_step_pm;
 *              drift_max_step_pm, landmark_max_step_pm, n_landmarks, each {id, x_pm, y_pm};
 *              haptic_un_per_pn, haptic_max_un, start_lifted (bool), interlock (bool),
 *                interlock_normal_pn, interlock_lateral_pn;
 *              creep_enable (bool), creep {gamma_ppm, t0_us, period_us};
 *                hyst_enable (bool), hyst[2] each {n, r_pm[16], w_q24[16],
 *                range_pm, origin_pm} (all FW_HYST_N_MAX entries);
 *              drift_filter, drift_kalman {period_us, walk_nm2_per_s,
 *                vel_prior_nm2_per_s2}, drift_scan_var_nm2;
 *              capacities: particles, wires, trench points
 *   in         joy_q15[2], load_pn, engaged (bool), n, each {sn_uv, sl_uv, piezo_pm[3]}
 *   out        force_pn[3], flags, code_n, code_l, tip_pm[3], target_pm[2],
 *              piezo_cmd_pm[2], load_pn, engaged (bool), haptic_un[3],
 *              sat_samples, interlock (int32)
 *   fix        place (bool), object_id, scan_pm[2]
 *   fix_out    result (int32), landmark (bool), model_pm[2], delta_pm[2]
 *   models     n_particles, each {id, x_pm, y_pm, radius_pm, flags};
 *              n_wires, each {id, a_pm[2], b_pm[2], diameter_pm, flags, axis_z_pm};
 *              drift_pm[2], litho (bool), trench_count, trench_from, each point
 *              from trench_from {x_pm, y_pm, depth_pm, width_pm, flags};
 *              interlock (bool), interlock_trips
 *   text       length u32, bytes
 *
 * Messages: INIT host -> board: config; board -> host: rule (int32), models.
 * STEP host -> board: in; board -> host: status (int32), out, step_ticks (u32: the
 *   board's timer around fw_card_step_block), board_ticks (u32: from the request
 *   read to the answer written, the marshalling and the models included), models.
 * FIX host -> board: fix; board -> host: status (int32), fix_out, models.
 * ERROR board -> host: text.
 */
#include "fw_marshal.h"

#include <stddef.h>
#include <string.h>

void fw_marshal_writer_init(fw_marshal_cursor_t *cur, uint8_t *buf, uint32_t cap)
{
    cur->w = buf;
    cur->r = NULL;
    cur->len = cap;
    cur->at = 0;
    cur->bad_field = NULL;
    cur->bad_value = 0;
}

void fw_marshal_reader_init(fw_marshal_cursor_t *cur, const uint8_t *buf, uint32_t len)
{
    cur->w = NULL;
    cur->r = buf;
    cur->len = len;
    cur->at = 0;
    cur->bad_field = NULL;
    cur->bad_value = 0;
}

bool fw_marshal_ok(const fw_marshal_cursor_t *cur) { return cur->bad_field == NULL; }

static void fail(fw_marshal_cursor_t *cur, const char *field, int32_t value)
{
    if (cur->bad_field == NULL) {
        cur->bad_field = field;
        cur->bad_value = value;
    }
}

/* Room for n more bytes, else the cursor goes bad naming field. */
static bool room(fw_marshal_cursor_t *cur, uint32_t n, const char *field)
{
    if (cur->bad_field != NULL) return false;
    if (cur->len - cur->at < n) {
        fail(cur, field, (int32_t)(n - (cur->len - cur->at)));
        return false;
    }
    return true;
}

void fw_marshal_put_u32_le(fw_marshal_cursor_t *cur, uint32_t v)
{
    if (cur->w == NULL) { fail(cur, "(a writer)", 0); return; }
    if (!room(cur, 4u, "(buffer full)")) return;
    uint8_t *p = cur->w + cur->at;
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
    p[2] = (uint8_t)((v >> 16) & 0xFFu);
    p[3] = (uint8_t)((v >> 24) & 0xFFu);
    cur->at += 4u;
}

void fw_marshal_put_i32_le(fw_marshal_cursor_t *cur, int32_t v) { fw_marshal_put_u32_le(cur, (uint32_t)v); }

static void put_bool(fw_marshal_cursor_t *cur, bool v)
{
    if (cur->w == NULL) { fail(cur, "(a writer)", 0); return; }
    if (!room(cur, 1u, "(buffer full)")) return;
    cur->w[cur->at++] = v ? 1u : 0u;
}

uint32_t fw_marshal_get_u32_le(fw_marshal_cursor_t *cur, const char *field)
{
    if (cur->r == NULL) { fail(cur, field, 0); return 0u; }
    if (!room(cur, 4u, field)) return 0u;
    const uint8_t *p = cur->r + cur->at;
    cur->at += 4u;
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

int32_t fw_marshal_get_i32_le(fw_marshal_cursor_t *cur, const char *field)
{
    const uint32_t u = fw_marshal_get_u32_le(cur, field);
    /* two's complement back without implementation-defined conversion */
    return (u <= 0x7FFFFFFFu) ? (int32_t)u : (int32_t)(u - 0x80000000u) - INT32_MAX - 1;
}

static bool get_bool(fw_marshal_cursor_t *cur, const char *field)
{
    if (cur->r == NULL) { fail(cur, field, 0); return false; }
    if (!room(cur, 1u, field)) return false;
    const uint8_t b = cur->r[cur->at++];
    if (b > 1u) fail(cur, field, (int32_t)b);
    return b == 1u;
}

/* A count in [0, capacity]. */
static int32_t get_count(fw_marshal_cursor_t *cur, const char *field, int32_t capacity)
{
    const int32_t n = fw_marshal_get_i32_le(cur, field);
    if (n < 0 || n > capacity) {
        fail(cur, field, n);
        return 0;
    }
    return fw_marshal_ok(cur) ? n : 0;
}

#define PUT(v) fw_marshal_put_i32_le(cur, (v))
#define GET(dst, name) ((dst) = fw_marshal_get_i32_le(cur, (name)))
#define GETU(dst, name) ((dst) = fw_marshal_get_u32_le(cur, (name)))

void fw_marshal_put_header_le(fw_marshal_cursor_t *cur, uint32_t kind, uint32_t payload_len)
{
    fw_marshal_put_u32_le(cur, FW_MARSHAL_MAGIC);
    fw_marshal_put_u32_le(cur, kind);
    fw_marshal_put_u32_le(cur, payload_len);
}

void fw_marshal_get_header_le(fw_marshal_cursor_t *cur, uint32_t *kind, uint32_t *payload_len)
{
    const uint32_t magic = fw_marshal_get_u32_le(cur, "header.magic");
    if (fw_marshal_ok(cur) && magic != FW_MARSHAL_MAGIC) fail(cur, "header.magic", (int32_t)magic);
    *kind = fw_marshal_get_u32_le(cur, "header.kind");
    *payload_len = fw_marshal_get_u32_le(cur, "header.payload_bytes");
}

void fw_marshal_patch_len_le(fw_marshal_cursor_t *cur, uint32_t header_at)
{
    if (!fw_marshal_ok(cur) || cur->w == NULL || header_at + FW_MARSHAL_HEADER_BYTES > cur->at) return;
    const uint32_t len = cur->at - header_at - FW_MARSHAL_HEADER_BYTES;
    uint8_t *p = cur->w + header_at + 8u;
    p[0] = (uint8_t)(len & 0xFFu);
    p[1] = (uint8_t)((len >> 8) & 0xFFu);
    p[2] = (uint8_t)((len >> 16) & 0xFFu);
    p[3] = (uint8_t)((len >> 24) & 0xFFu);
}

static void put_board(fw_marshal_cursor_t *cur, const fw_board_config_t *b)
{
    PUT(b->adc_bits);
    PUT(b->normal_gain_pn_per_v);
    PUT(b->lateral_gain_pn_per_v);
    PUT(b->deflection_pm_per_v);
    PUT(b->tip_height_nm);
    PUT(b->lever_length_nm);
    PUT(b->disp_n_pm_per_v);
    PUT(b->disp_l_pm_per_v);
    PUT(b->scan_angle_mdeg);
    PUT(b->mu_ppm);
    PUT(b->adhesion_pn);
    PUT(b->scan_center_pm[0]);
    PUT(b->scan_center_pm[1]);
    PUT(b->scan_half_range_pm);
    PUT(b->kappa_q16);
    PUT(b->filter_log2);
    PUT(b->theta_min_disp_pm);
}

static void get_board(fw_marshal_cursor_t *cur, fw_board_config_t *b)
{
    GET(b->adc_bits, "config.board.adc_bits");
    GET(b->normal_gain_pn_per_v, "config.board.normal_gain_pn_per_v");
    GET(b->lateral_gain_pn_per_v, "config.board.lateral_gain_pn_per_v");
    GET(b->deflection_pm_per_v, "config.board.deflection_pm_per_v");
    GET(b->tip_height_nm, "config.board.tip_height_nm");
    GET(b->lever_length_nm, "config.board.lever_length_nm");
    GET(b->disp_n_pm_per_v, "config.board.disp_n_pm_per_v");
    GET(b->disp_l_pm_per_v, "config.board.disp_l_pm_per_v");
    GET(b->scan_angle_mdeg, "config.board.scan_angle_mdeg");
    GET(b->mu_ppm, "config.board.mu_ppm");
    GET(b->adhesion_pn, "config.board.adhesion_pn");
    GET(b->scan_center_pm[0], "config.board.scan_center_pm[0]");
    GET(b->scan_center_pm[1], "config.board.scan_center_pm[1]");
    GET(b->scan_half_range_pm, "config.board.scan_half_range_pm");
    GET(b->kappa_q16, "config.board.kappa_q16");
    GET(b->filter_log2, "config.board.filter_log2");
    GET(b->theta_min_disp_pm, "config.board.theta_min_disp_pm");
}

/* The objects: particles, wires, lithography, drift and landmarks. */
static void put_objects(fw_marshal_cursor_t *cur, const fw_card_config_t *c)
{
    PUT(c->n_particles);
    for (int32_t i = 0; i < c->n_particles; ++i) {
        const fw_card_particle_t *p = &c->particles[i];
        PUT(p->id); PUT(p->x_pm); PUT(p->y_pm); PUT(p->radius_pm);
    }
    PUT(c->particle_mu_ppm);
    PUT(c->particle_adhesion_pn);
    PUT(c->particle_shear_kpa);
    PUT(c->particle_contact_area_nm2);
    PUT(c->particle_margin_pn);
    PUT(c->n_wires);
    for (int32_t i = 0; i < c->n_wires; ++i) {
        const fw_card_wire_t *w = &c->wires[i];
        PUT(w->id); PUT(w->a_pm[0]); PUT(w->a_pm[1]); PUT(w->b_pm[0]); PUT(w->b_pm[1]); PUT(w->diameter_pm);
    }
    PUT(c->wire_friction_pn_per_um);
    PUT(c->wire_mu_ppm);
    put_bool(cur, c->litho);
    PUT(c->litho_threshold_pn);
    PUT(c->litho_depth_pm_per_pn);
    PUT(c->litho_step_pm);
    PUT(c->drift_max_step_pm);
    PUT(c->landmark_max_step_pm);
    PUT(c->n_landmarks);
    for (int32_t i = 0; i < c->n_landmarks; ++i) {
        const fw_card_landmark_t *l = &c->landmarks[i];
        PUT(l->id); PUT(l->x_pm); PUT(l->y_pm);
    }
}

static void get_objects(fw_marshal_cursor_t *cur, fw_card_config_t *c, const fw_marshal_config_arrays_t *arr)
{
    c->n_particles = get_count(cur, "config.n_particles", arr->particle_capacity);
    c->particles = c->n_particles > 0 ? arr->particles : NULL;
    for (int32_t i = 0; i < c->n_particles; ++i) {
        fw_card_particle_t *p = &arr->particles[i];
        GET(p->id, "config.particles.id"); GET(p->x_pm, "config.particles.x_pm");
        GET(p->y_pm, "config.particles.y_pm"); GET(p->radius_pm, "config.particles.radius_pm");
    }
    GET(c->particle_mu_ppm, "config.particle_mu_ppm");
    GET(c->particle_adhesion_pn, "config.particle_adhesion_pn");
    GET(c->particle_shear_kpa, "config.particle_shear_kpa");
    GET(c->particle_contact_area_nm2, "config.particle_contact_area_nm2");
    GET(c->particle_margin_pn, "config.particle_margin_pn");
    c->n_wires = get_count(cur, "config.n_wires", arr->wire_capacity);
    c->wires = c->n_wires > 0 ? arr->wires : NULL;
    for (int32_t i = 0; i < c->n_wires; ++i) {
        fw_card_wire_t *w = &arr->wires[i];
        GET(w->id, "config.wires.id");
        GET(w->a_pm[0], "config.wires.a_pm[0]"); GET(w->a_pm[1], "config.wires.a_pm[1]");
        GET(w->b_pm[0], "config.wires.b_pm[0]"); GET(w->b_pm[1], "config.wires.b_pm[1]");
        GET(w->diameter_pm, "config.wires.diameter_pm");
    }
    GET(c->wire_friction_pn_per_um, "config.wire_friction_pn_per_um");
    GET(c->wire_mu_ppm, "config.wire_mu_ppm");
    c->litho = get_bool(cur, "config.litho");
    GET(c->litho_threshold_pn, "config.litho_threshold_pn");
    GET(c->litho_depth_pm_per_pn, "config.litho_depth_pm_per_pn");
    GET(c->litho_step_pm, "config.litho_step_pm");
    GET(c->drift_max_step_pm, "config.drift_max_step_pm");
    GET(c->landmark_max_step_pm, "config.landmark_max_step_pm");
    c->n_landmarks = get_count(cur, "config.n_landmarks", arr->landmark_capacity);
    c->landmarks = c->n_landmarks > 0 ? arr->landmarks : NULL;
    for (int32_t i = 0; i < c->n_landmarks; ++i) {
        fw_card_landmark_t *l = &arr->landmarks[i];
        GET(l->id, "config.landmarks.id"); GET(l->x_pm, "config.landmarks.x_pm"); GET(l->y_pm, "config.landmarks.y_pm");
    }
}

static void put_scanner(fw_marshal_cursor_t *cur, const fw_card_config_t *c)
{
    int i, k;
    put_bool(cur, c->creep_enable);
    PUT(c->creep.gamma_ppm);
    PUT(c->creep.t0_us);
    PUT(c->creep.period_us);
    put_bool(cur, c->hyst_enable);
    for (i = 0; i < 2; i++) {
        PUT(c->hyst[i].n);
        for (k = 0; k < FW_HYST_N_MAX; k++) {
            PUT(c->hyst[i].r_pm[k]);
            PUT(c->hyst[i].w_q24[k]);
        }
        PUT(c->hyst[i].range_pm);
        PUT(c->hyst[i].origin_pm);
    }
    PUT(c->drift_filter);
    PUT(c->drift_kalman.period_us);
    PUT(c->drift_kalman.walk_nm2_per_s);
    PUT(c->drift_kalman.vel_prior_nm2_per_s2);
    PUT(c->drift_scan_var_nm2);
}

static void get_scanner(fw_marshal_cursor_t *cur, fw_card_config_t *c)
{
    int i, k;
    c->creep_enable = get_bool(cur, "config.creep_enable");
    GET(c->creep.gamma_ppm, "config.creep.gamma_ppm");
    GET(c->creep.t0_us, "config.creep.t0_us");
    GET(c->creep.period_us, "config.creep.period_us");
    c->hyst_enable = get_bool(cur, "config.hyst_enable");
    for (i = 0; i < 2; i++) {
        GET(c->hyst[i].n, "config.hyst.n");
        for (k = 0; k < FW_HYST_N_MAX; k++) {
            GET(c->hyst[i].r_pm[k], "config.hyst.r_pm");
            GET(c->hyst[i].w_q24[k], "config.hyst.w_q24");
        }
        GET(c->hyst[i].range_pm, "config.hyst.range_pm");
        GET(c->hyst[i].origin_pm, "config.hyst.origin_pm");
    }
    GET(c->drift_filter, "config.drift_filter");
    GET(c->drift_kalman.period_us, "config.drift_kalman.period_us");
    GET(c->drift_kalman.walk_nm2_per_s, "config.drift_kalman.walk_nm2_per_s");
    GET(c->drift_kalman.vel_prior_nm2_per_s2, "config.drift_kalman.vel_prior_nm2_per_s2");
    GET(c->drift_scan_var_nm2, "config.drift_scan_var_nm2");
}

void fw_marshal_put_config_le(fw_marshal_cursor_t *cur, const fw_card_config_t *cfg, const fw_card_storage_t *st)
{
    put_board(cur, &cfg->board);
    PUT(cfg->word_bits);
    PUT(cfg->tip_radius_pm);
    PUT(cfg->tip_half_angle_mdeg);
    put_bool(cur, cfg->down_force);
    put_objects(cur, cfg);
    PUT(cfg->haptic_un_per_pn);
    PUT(cfg->haptic_max_un);
    put_bool(cur, cfg->start_lifted);
    put_bool(cur, cfg->interlock);
    PUT(cfg->interlock_normal_pn);
    PUT(cfg->interlock_lateral_pn);
    put_scanner(cur, cfg);
    PUT(st->particle_capacity);
    PUT(st->wire_capacity);
    PUT(st->trench_capacity);
}

void fw_marshal_get_config_le(fw_marshal_cursor_t *cur, fw_card_config_t *cfg, const fw_marshal_config_arrays_t *arr,
                              int32_t capacities[3])
{
    get_board(cur, &cfg->board);
    GET(cfg->word_bits, "config.word_bits");
    GET(cfg->tip_radius_pm, "config.tip_radius_pm");
    GET(cfg->tip_half_angle_mdeg, "config.tip_half_angle_mdeg");
    cfg->down_force = get_bool(cur, "config.down_force");
    get_objects(cur, cfg, arr);
    GET(cfg->haptic_un_per_pn, "config.haptic_un_per_pn");
    GET(cfg->haptic_max_un, "config.haptic_max_un");
    cfg->start_lifted = get_bool(cur, "config.start_lifted");
    cfg->interlock = get_bool(cur, "config.interlock");
    GET(cfg->interlock_normal_pn, "config.interlock_normal_pn");
    GET(cfg->interlock_lateral_pn, "config.interlock_lateral_pn");
    get_scanner(cur, cfg);
    GET(capacities[0], "storage.particle_capacity");
    GET(capacities[1], "storage.wire_capacity");
    GET(capacities[2], "storage.trench_capacity");
}

void fw_marshal_put_in_le(fw_marshal_cursor_t *cur, const fw_card_in_t *in)
{
    PUT(in->pose.joy_q15[0]);
    PUT(in->pose.joy_q15[1]);
    PUT(in->pose.load_pn);
    put_bool(cur, in->pose.engaged);
    PUT(in->n);
    for (int32_t i = 0; i < in->n; ++i) {
        const fw_sample_in_t *s = &in->samples[i];
        PUT(s->sn_uv); PUT(s->sl_uv); PUT(s->piezo_pm[0]); PUT(s->piezo_pm[1]); PUT(s->piezo_pm[2]);
    }
}

void fw_marshal_get_in_le(fw_marshal_cursor_t *cur, fw_card_in_t *in, fw_sample_in_t *samples, int32_t capacity)
{
    GET(in->pose.joy_q15[0], "in.pose.joy_q15[0]");
    GET(in->pose.joy_q15[1], "in.pose.joy_q15[1]");
    GET(in->pose.load_pn, "in.pose.load_pn");
    in->pose.engaged = get_bool(cur, "in.pose.engaged");
    in->n = get_count(cur, "in.n", capacity);
    in->samples = samples;
    for (int32_t i = 0; i < in->n; ++i) {
        fw_sample_in_t *s = &samples[i];
        GET(s->sn_uv, "in.samples.sn_uv"); GET(s->sl_uv, "in.samples.sl_uv");
        GET(s->piezo_pm[0], "in.samples.piezo_pm[0]"); GET(s->piezo_pm[1], "in.samples.piezo_pm[1]");
        GET(s->piezo_pm[2], "in.samples.piezo_pm[2]");
    }
}

void fw_marshal_put_out_le(fw_marshal_cursor_t *cur, const fw_card_out_t *o)
{
    for (int k = 0; k < 3; ++k) PUT(o->force_pn[k]);
    fw_marshal_put_u32_le(cur, o->flags);
    PUT(o->code_n);
    PUT(o->code_l);
    for (int k = 0; k < 3; ++k) PUT(o->tip_pm[k]);
    PUT(o->target_pm[0]); PUT(o->target_pm[1]);
    PUT(o->piezo_cmd_pm[0]); PUT(o->piezo_cmd_pm[1]);
    PUT(o->load_pn);
    put_bool(cur, o->engaged);
    for (int k = 0; k < 3; ++k) PUT(o->haptic_un[k]);
    fw_marshal_put_u32_le(cur, o->sat_samples);
    PUT((int32_t)o->interlock);
}

void fw_marshal_get_out_le(fw_marshal_cursor_t *cur, fw_card_out_t *o)
{
    for (int k = 0; k < 3; ++k) GET(o->force_pn[k], "out.force_pn");
    GETU(o->flags, "out.flags");
    GET(o->code_n, "out.code_n");
    GET(o->code_l, "out.code_l");
    for (int k = 0; k < 3; ++k) GET(o->tip_pm[k], "out.tip_pm");
    GET(o->target_pm[0], "out.target_pm[0]"); GET(o->target_pm[1], "out.target_pm[1]");
    GET(o->piezo_cmd_pm[0], "out.piezo_cmd_pm[0]"); GET(o->piezo_cmd_pm[1], "out.piezo_cmd_pm[1]");
    GET(o->load_pn, "out.load_pn");
    o->engaged = get_bool(cur, "out.engaged");
    for (int k = 0; k < 3; ++k) GET(o->haptic_un[k], "out.haptic_un");
    GETU(o->sat_samples, "out.sat_samples");
    const int32_t g = fw_marshal_get_i32_le(cur, "out.interlock");
    if (g < (int32_t)FW_GUARD_ARMED || g > (int32_t)FW_GUARD_HOLDING) fail(cur, "out.interlock", g);
    o->interlock = (fw_guard_state_t)g;
}

void fw_marshal_put_fix_le(fw_marshal_cursor_t *cur, const fw_marshal_fix_t *f)
{
    put_bool(cur, f->place);
    PUT(f->object_id);
    PUT(f->scan_pm[0]);
    PUT(f->scan_pm[1]);
}

void fw_marshal_get_fix_le(fw_marshal_cursor_t *cur, fw_marshal_fix_t *f)
{
    f->place = get_bool(cur, "fix.place");
    GET(f->object_id, "fix.object_id");
    GET(f->scan_pm[0], "fix.scan_pm[0]");
    GET(f->scan_pm[1], "fix.scan_pm[1]");
}

void fw_marshal_put_fix_out_le(fw_marshal_cursor_t *cur, const fw_card_fix_out_t *o)
{
    PUT((int32_t)o->result);
    put_bool(cur, o->landmark);
    PUT(o->model_pm[0]); PUT(o->model_pm[1]);
    PUT(o->delta_pm[0]); PUT(o->delta_pm[1]);
}

void fw_marshal_get_fix_out_le(fw_marshal_cursor_t *cur, fw_card_fix_out_t *o)
{
    const int32_t r = fw_marshal_get_i32_le(cur, "fix_out.result");
    if (r < (int32_t)FW_CARD_FIX_APPLIED || r > (int32_t)FW_CARD_FIX_NOT_DRIFT) fail(cur, "fix_out.result", r);
    o->result = (fw_card_fix_result_t)r;
    o->landmark = get_bool(cur, "fix_out.landmark");
    GET(o->model_pm[0], "fix_out.model_pm[0]"); GET(o->model_pm[1], "fix_out.model_pm[1]");
    GET(o->delta_pm[0], "fix_out.delta_pm[0]"); GET(o->delta_pm[1], "fix_out.delta_pm[1]");
}

static void put_trench(fw_marshal_cursor_t *cur, const fw_models_t *m, int32_t from)
{
    PUT(m->trench_count);
    PUT(from);
    for (int32_t i = from; i < m->trench_count; ++i) {
        const fw_trench_point_t *p = &m->trench[i];
        PUT(p->x_pm); PUT(p->y_pm); PUT(p->depth_pm); PUT(p->width_pm);
        fw_marshal_put_u32_le(cur, p->flags);
    }
}

static void get_trench(fw_marshal_cursor_t *cur, fw_models_t *m, fw_trench_point_t *store, int32_t capacity)
{
    const int32_t count = get_count(cur, "models.trench_count", capacity);
    const int32_t from = get_count(cur, "models.trench_from", count);
    for (int32_t i = from; i < count; ++i) {
        fw_trench_point_t *p = &store[i];
        GET(p->x_pm, "models.trench.x_pm"); GET(p->y_pm, "models.trench.y_pm");
        GET(p->depth_pm, "models.trench.depth_pm"); GET(p->width_pm, "models.trench.width_pm");
        GETU(p->flags, "models.trench.flags");
    }
    m->trench = store;
    m->trench_count = count;
}

void fw_marshal_put_models_le(fw_marshal_cursor_t *cur, const fw_models_t *m, int32_t trench_from)
{
    PUT(m->n_particles);
    for (int32_t i = 0; i < m->n_particles; ++i) {
        const fw_models_particle_t *p = &m->particles[i];
        PUT(p->id); PUT(p->x_pm); PUT(p->y_pm); PUT(p->radius_pm);
        fw_marshal_put_u32_le(cur, p->flags);
    }
    PUT(m->n_wires);
    for (int32_t i = 0; i < m->n_wires; ++i) {
        const fw_models_wire_t *w = &m->wires[i];
        PUT(w->id); PUT(w->a_pm[0]); PUT(w->a_pm[1]); PUT(w->b_pm[0]); PUT(w->b_pm[1]); PUT(w->diameter_pm);
        fw_marshal_put_u32_le(cur, w->flags);
        PUT(w->axis_z_pm);
    }
    PUT(m->drift_pm[0]);
    PUT(m->drift_pm[1]);
    put_bool(cur, m->litho);
    put_trench(cur, m, trench_from < 0 ? 0 : (trench_from > m->trench_count ? m->trench_count : trench_from));
    put_bool(cur, m->interlock);
    fw_marshal_put_u32_le(cur, m->interlock_trips);
}

void fw_marshal_get_models_le(fw_marshal_cursor_t *cur, fw_models_t *m, fw_trench_point_t *trench_store,
                              int32_t trench_capacity)
{
    m->n_particles = get_count(cur, "models.n_particles", m->particle_capacity);
    for (int32_t i = 0; i < m->n_particles; ++i) {
        fw_models_particle_t *p = &m->particles[i];
        GET(p->id, "models.particles.id"); GET(p->x_pm, "models.particles.x_pm"); GET(p->y_pm, "models.particles.y_pm");
        GET(p->radius_pm, "models.particles.radius_pm"); GETU(p->flags, "models.particles.flags");
    }
    m->n_wires = get_count(cur, "models.n_wires", m->wire_capacity);
    for (int32_t i = 0; i < m->n_wires; ++i) {
        fw_models_wire_t *w = &m->wires[i];
        GET(w->id, "models.wires.id");
        GET(w->a_pm[0], "models.wires.a_pm[0]"); GET(w->a_pm[1], "models.wires.a_pm[1]");
        GET(w->b_pm[0], "models.wires.b_pm[0]"); GET(w->b_pm[1], "models.wires.b_pm[1]");
        GET(w->diameter_pm, "models.wires.diameter_pm"); GETU(w->flags, "models.wires.flags");
        GET(w->axis_z_pm, "models.wires.axis_z_pm");
    }
    GET(m->drift_pm[0], "models.drift_pm[0]");
    GET(m->drift_pm[1], "models.drift_pm[1]");
    m->litho = get_bool(cur, "models.litho");
    get_trench(cur, m, trench_store, trench_capacity);
    m->interlock = get_bool(cur, "models.interlock");
    GETU(m->interlock_trips, "models.interlock_trips");
}

void fw_marshal_put_text_le(fw_marshal_cursor_t *cur, const char *text)
{
    const uint32_t n = (uint32_t)strlen(text);
    fw_marshal_put_u32_le(cur, n);
    if (cur->w == NULL || !room(cur, n, "(buffer full)")) return;
    memcpy(cur->w + cur->at, text, n);
    cur->at += n;
}

void fw_marshal_get_text_le(fw_marshal_cursor_t *cur, char *text, uint32_t cap)
{
    const uint32_t n = fw_marshal_get_u32_le(cur, "text.length");
    if (cap > 0u) text[0] = '\0';
    if (!room(cur, n, "text") || cap == 0u) return;
    const uint32_t k = n < cap - 1u ? n : cap - 1u;
    memcpy(text, cur->r + cur->at, k);
    text[k] = '\0';
    cur->at += n;
}
