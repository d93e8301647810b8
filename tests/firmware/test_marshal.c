/* test_marshal.c - fw_marshal: every struct the link carries, round-tripped
 * through the bytes (host and Cortex-M4 builds), the byte order, and the
 * errors that name a field. Each struct is zeroed before it is filled or
 * read, so a whole-struct compare sees every field (and zero padding). */
#include <string.h>

#include "unity.h"
#include "fw_marshal.h"
#include "test_util.h"

void setUp(void) {}
void tearDown(void) {}

static uint32_t rng = 0x12345678u;
static int32_t draw(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 17;
    rng ^= rng << 5;
    switch (rng & 7u) {
    case 0: return INT32_MIN;
    case 1: return INT32_MAX;
    case 2: return -1;
    default: return (int32_t)(rng >> 1) - 0x20000000;
    }
}

static uint8_t buf[65536];

static void fill_board(fw_board_config_t *b)
{
    b->adc_bits = draw(); b->normal_gain_pn_per_v = draw(); b->lateral_gain_pn_per_v = draw();
    b->deflection_pm_per_v = draw(); b->tip_height_nm = draw(); b->lever_length_nm = draw();
    b->disp_n_pm_per_v = draw(); b->disp_l_pm_per_v = draw(); b->scan_angle_mdeg = draw(); b->mu_ppm = draw();
    b->adhesion_pn = draw(); b->scan_center_pm[0] = draw(); b->scan_center_pm[1] = draw();
    b->scan_half_range_pm = draw(); b->kappa_q16 = draw(); b->filter_log2 = draw(); b->theta_min_disp_pm = draw();
}

static fw_card_particle_t parts[3], parts_back[4];
static fw_card_wire_t wires[2], wires_back[2];
static fw_card_landmark_t marks[2], marks_back[2];

static void fill_config(fw_card_config_t *c, bool flag)
{
    memset(c, 0, sizeof *c);
    fill_board(&c->board);
    c->word_bits = draw(); c->tip_radius_pm = draw(); c->tip_half_angle_mdeg = draw(); c->down_force = flag;
    for (int i = 0; i < 3; ++i) { parts[i].id = draw(); parts[i].x_pm = draw(); parts[i].y_pm = draw(); parts[i].radius_pm = draw(); }
    c->particles = parts; c->n_particles = 3;
    c->particle_mu_ppm = draw(); c->particle_adhesion_pn = draw(); c->particle_shear_kpa = draw();
    c->particle_contact_area_nm2 = draw(); c->particle_margin_pn = draw();
    for (int i = 0; i < 2; ++i) {
        wires[i].id = draw(); wires[i].a_pm[0] = draw(); wires[i].a_pm[1] = draw();
        wires[i].b_pm[0] = draw(); wires[i].b_pm[1] = draw(); wires[i].diameter_pm = draw();
        marks[i].id = draw(); marks[i].x_pm = draw(); marks[i].y_pm = draw();
    }
    c->wires = wires; c->n_wires = 2; c->wire_friction_pn_per_um = draw(); c->wire_mu_ppm = draw();
    c->litho = !flag; c->litho_threshold_pn = draw(); c->litho_depth_pm_per_pn = draw(); c->litho_step_pm = draw();
    c->drift_max_step_pm = draw(); c->landmark_max_step_pm = draw(); c->landmarks = marks; c->n_landmarks = 2;
    c->haptic_un_per_pn = draw(); c->haptic_max_un = draw(); c->start_lifted = flag; c->interlock = !flag;
    c->interlock_normal_pn = draw(); c->interlock_lateral_pn = draw();
    c->creep_enable = flag; c->creep.gamma_ppm = draw(); c->creep.t0_us = draw(); c->creep.period_us = draw();
    c->hyst_enable = !flag;
    c->drift_filter = draw(); c->drift_kalman.period_us = draw(); c->drift_kalman.walk_nm2_per_s = draw();
    c->drift_kalman.vel_prior_nm2_per_s2 = draw(); c->drift_scan_var_nm2 = draw();
    for (int i = 0; i < 2; ++i) {
        c->hyst[i].n = draw(); c->hyst[i].range_pm = draw(); c->hyst[i].origin_pm = draw();
        for (int k = 0; k < FW_HYST_N_MAX; ++k) { c->hyst[i].r_pm[k] = draw(); c->hyst[i].w_q24[k] = draw(); }
    }
}

static void test_config_round_trips_with_its_arrays_and_capacities(void)
{
    for (int pass = 0; pass < 2; ++pass) {
        fw_card_config_t c, back;
        fill_config(&c, pass == 0);
        const fw_card_storage_t st = {NULL, 3, NULL, 2, NULL, 8192, NULL, 0};
        fw_marshal_cursor_t w, r;
        fw_marshal_writer_init(&w, buf, sizeof buf);
        fw_marshal_put_config_le(&w, &c, &st);
        TEST_ASSERT_TRUE(fw_marshal_ok(&w));
        const fw_marshal_config_arrays_t arr = {parts_back, 4, wires_back, 2, marks_back, 2};
        int32_t cap[3] = {0, 0, 0};
        memset(&back, 0, sizeof back);
        fw_marshal_reader_init(&r, buf, w.at);
        fw_marshal_get_config_le(&r, &back, &arr, cap);
        TEST_ASSERT_TRUE(fw_marshal_ok(&r));
        TEST_ASSERT_EQUAL_UINT32(w.at, r.at);
        TEST_ASSERT_EQUAL_MEMORY(parts, back.particles, sizeof parts);
        TEST_ASSERT_EQUAL_MEMORY(wires, back.wires, sizeof wires);
        TEST_ASSERT_EQUAL_MEMORY(marks, back.landmarks, sizeof marks);
        back.particles = parts; back.wires = wires; back.landmarks = marks;
        TEST_ASSERT_EQUAL_MEMORY(&c, &back, sizeof c);
        TEST_ASSERT_EQUAL_INT32(3, cap[0]); TEST_ASSERT_EQUAL_INT32(2, cap[1]); TEST_ASSERT_EQUAL_INT32(8192, cap[2]);
    }
}

static void test_block_in_and_out_round_trip(void)
{
    fw_sample_in_t s[5], s_back[5];
    fw_card_in_t in, in_back;
    memset(&in, 0, sizeof in); memset(&in_back, 0, sizeof in_back); memset(s, 0, sizeof s); memset(s_back, 0, sizeof s_back);
    for (int i = 0; i < 5; ++i) { s[i].sn_uv = draw(); s[i].sl_uv = draw(); s[i].piezo_pm[0] = draw(); s[i].piezo_pm[1] = draw(); s[i].piezo_pm[2] = draw(); }
    in.samples = s; in.n = 5; in.pose.joy_q15[0] = draw(); in.pose.joy_q15[1] = draw(); in.pose.load_pn = draw(); in.pose.engaged = true;
    fw_card_out_t o, o_back;
    memset(&o, 0, sizeof o); memset(&o_back, 0, sizeof o_back);
    for (int k = 0; k < 3; ++k) { o.force_pn[k] = draw(); o.tip_pm[k] = draw(); o.haptic_un[k] = draw(); }
    o.flags = (uint32_t)draw(); o.code_n = draw(); o.code_l = draw(); o.target_pm[0] = draw(); o.target_pm[1] = draw();
    o.piezo_cmd_pm[0] = draw(); o.piezo_cmd_pm[1] = draw(); o.load_pn = draw(); o.engaged = true;
    o.sat_samples = (uint32_t)draw(); o.interlock = FW_GUARD_HOLDING;
    fw_marshal_cursor_t w, r;
    fw_marshal_writer_init(&w, buf, sizeof buf);
    fw_marshal_put_in_le(&w, &in);
    fw_marshal_put_out_le(&w, &o);
    fw_marshal_reader_init(&r, buf, w.at);
    fw_marshal_get_in_le(&r, &in_back, s_back, 5);
    fw_marshal_get_out_le(&r, &o_back);
    TEST_ASSERT_TRUE(fw_marshal_ok(&r));
    TEST_ASSERT_EQUAL_UINT32(w.at, r.at);
    TEST_ASSERT_EQUAL_MEMORY(s, s_back, sizeof s);
    TEST_ASSERT_TRUE(in_back.samples == s_back);
    in_back.samples = s;
    TEST_ASSERT_EQUAL_MEMORY(&in, &in_back, sizeof in);
    TEST_ASSERT_EQUAL_MEMORY(&o, &o_back, sizeof o);
}

static void test_fix_and_its_answer_round_trip(void)
{
    fw_marshal_fix_t f, f_back;
    fw_card_fix_out_t o, o_back;
    memset(&f, 0, sizeof f); memset(&f_back, 0, sizeof f_back); memset(&o, 0, sizeof o); memset(&o_back, 0, sizeof o_back);
    f.place = true; f.object_id = draw(); f.scan_pm[0] = draw(); f.scan_pm[1] = draw();
    o.result = FW_CARD_FIX_NOT_DRIFT; o.landmark = true; o.model_pm[0] = draw(); o.model_pm[1] = draw(); o.delta_pm[0] = draw(); o.delta_pm[1] = draw();
    fw_marshal_cursor_t w, r;
    fw_marshal_writer_init(&w, buf, sizeof buf);
    fw_marshal_put_fix_le(&w, &f);
    fw_marshal_put_fix_out_le(&w, &o);
    fw_marshal_reader_init(&r, buf, w.at);
    fw_marshal_get_fix_le(&r, &f_back);
    fw_marshal_get_fix_out_le(&r, &o_back);
    TEST_ASSERT_TRUE(fw_marshal_ok(&r));
    TEST_ASSERT_EQUAL_MEMORY(&f, &f_back, sizeof f);
    TEST_ASSERT_EQUAL_MEMORY(&o, &o_back, sizeof o);
}

static void test_models_round_trip_and_trench_points_arrive_incrementally(void)
{
    fw_models_particle_t p[2], p_back[2];
    fw_models_wire_t wr[1], wr_back[1];
    fw_trench_point_t t[4], t_back[4];
    memset(p, 0, sizeof p); memset(p_back, 0, sizeof p_back); memset(wr, 0, sizeof wr); memset(wr_back, 0, sizeof wr_back);
    memset(t, 0, sizeof t); memset(t_back, 0, sizeof t_back);
    for (int i = 0; i < 2; ++i) { p[i].id = draw(); p[i].x_pm = draw(); p[i].y_pm = draw(); p[i].radius_pm = draw(); p[i].flags = (uint32_t)draw(); }
    wr[0].id = draw(); wr[0].a_pm[0] = draw(); wr[0].a_pm[1] = draw(); wr[0].b_pm[0] = draw(); wr[0].b_pm[1] = draw();
    wr[0].diameter_pm = draw(); wr[0].flags = (uint32_t)draw(); wr[0].axis_z_pm = draw();
    for (int i = 0; i < 4; ++i) { t[i].x_pm = draw(); t[i].y_pm = draw(); t[i].depth_pm = draw(); t[i].width_pm = draw(); t[i].flags = (uint32_t)draw(); }
    fw_models_t m, back;
    memset(&m, 0, sizeof m);
    memset(&back, 0, sizeof back);
    m.particles = p; m.particle_capacity = 2; m.n_particles = 2;
    m.wires = wr; m.wire_capacity = 1; m.n_wires = 1;
    m.litho = true; m.trench = t; m.trench_count = 3; m.drift_pm[0] = draw(); m.drift_pm[1] = draw();
    m.interlock = true; m.interlock_trips = 17u;
    back.particles = p_back; back.particle_capacity = 2; back.wires = wr_back; back.wire_capacity = 1;
    fw_marshal_cursor_t w, r;
    fw_marshal_writer_init(&w, buf, sizeof buf);
    fw_marshal_put_models_le(&w, &m, 0);   /* points 0..2 */
    m.trench_count = 4;
    fw_marshal_put_models_le(&w, &m, 3);   /* then point 3 alone */
    fw_marshal_reader_init(&r, buf, w.at);
    fw_marshal_get_models_le(&r, &back, t_back, 4);
    TEST_ASSERT_EQUAL_INT32(3, back.trench_count);
    fw_marshal_get_models_le(&r, &back, t_back, 4);
    TEST_ASSERT_TRUE(fw_marshal_ok(&r));
    TEST_ASSERT_EQUAL_UINT32(w.at, r.at);
    TEST_ASSERT_EQUAL_MEMORY(p, p_back, sizeof p);
    TEST_ASSERT_EQUAL_MEMORY(wr, wr_back, sizeof wr);
    TEST_ASSERT_EQUAL_MEMORY(t, t_back, sizeof t);
    TEST_ASSERT_TRUE(back.trench == t_back);
    back.particles = p; back.wires = wr; back.trench = t;
    TEST_ASSERT_EQUAL_MEMORY(&m, &back, sizeof m);
}

static void test_bytes_are_little_endian_field_by_field(void)
{
    const fw_marshal_fix_t f = {true, 0x01020304, {-2, 0x7F000080}};
    static const uint8_t want[] = {1, 4, 3, 2, 1, 0xFE, 0xFF, 0xFF, 0xFF, 0x80, 0, 0, 0x7F};
    fw_marshal_cursor_t w;
    fw_marshal_writer_init(&w, buf, sizeof buf);
    fw_marshal_put_fix_le(&w, &f);
    TEST_ASSERT_EQUAL_UINT32(sizeof want, w.at);
    TEST_ASSERT_EQUAL_MEMORY(want, buf, sizeof want);
    fw_marshal_writer_init(&w, buf, sizeof buf);
    fw_marshal_put_header_le(&w, FW_MARSHAL_STEP, 0u);
    fw_marshal_put_i32_le(&w, 7);
    fw_marshal_patch_len_le(&w, 0u);
    TEST_ASSERT_EQUAL_MEMORY("AFMB\x02\0\0\0\x04\0\0\0\x07\0\0\0", buf, 16);
}

static void test_errors_name_the_field_and_value(void)
{
    fw_marshal_fix_t f = {false, 5, {1, 2}};
    fw_marshal_cursor_t w, r;
    fw_marshal_writer_init(&w, buf, sizeof buf);
    fw_marshal_put_fix_le(&w, &f);
    buf[0] = 2;   /* a bool that is neither 0 nor 1 */
    fw_marshal_reader_init(&r, buf, w.at);
    fw_marshal_get_fix_le(&r, &f);
    TEST_ASSERT_EQUAL_STRING("fix.place", r.bad_field);
    TEST_ASSERT_EQUAL_INT32(2, r.bad_value);
    buf[0] = 1;
    fw_marshal_reader_init(&r, buf, w.at - 2u);   /* truncated in scan_pm[1] */
    fw_marshal_get_fix_le(&r, &f);
    TEST_ASSERT_EQUAL_STRING("fix.scan_pm[1]", r.bad_field);
    TEST_ASSERT_EQUAL_INT32(2, r.bad_value);   /* two bytes missing */
    fw_sample_in_t s[2] = {{0}};   /* two written (n = 2), room for one when read back */
    fw_card_in_t in = {s, 2, {{0, 0}, 0, false}};
    fw_marshal_writer_init(&w, buf, sizeof buf);
    fw_marshal_put_in_le(&w, &in);
    fw_marshal_reader_init(&r, buf, w.at);
    fw_marshal_get_in_le(&r, &in, s, 1);   /* more samples than room */
    TEST_ASSERT_EQUAL_STRING("in.n", r.bad_field);
    TEST_ASSERT_EQUAL_INT32(2, r.bad_value);
    fw_marshal_writer_init(&w, buf, 3u);
    fw_marshal_put_i32_le(&w, 1);
    TEST_ASSERT_FALSE(fw_marshal_ok(&w));
    uint32_t kind, len;
    memcpy(buf, "AFMX\1\0\0\0\0\0\0\0", 12);
    fw_marshal_reader_init(&r, buf, 12u);
    fw_marshal_get_header_le(&r, &kind, &len);
    TEST_ASSERT_EQUAL_STRING("header.magic", r.bad_field);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_config_round_trips_with_its_arrays_and_capacities);
    RUN_TEST(test_block_in_and_out_round_trip);
    RUN_TEST(test_fix_and_its_answer_round_trip);
    RUN_TEST(test_models_round_trip_and_trench_points_arrive_incrementally);
    RUN_TEST(test_bytes_are_little_endian_field_by_field);
    RUN_TEST(test_errors_name_the_field_and_value);
    return UNITY_END();
}
