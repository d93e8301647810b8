/*
 * afm_board.c - the card on its processor, in the loop (pil.md): a
 * bare-metal program for the mps2-an386 board (Cortex-M4) under
 * qemu-system-arm, that runs the same firmware library the host build runs.
 *
 * Usage (semihosting command line): afm_board TO_BOARD FROM_BOARD
 * [fault=KIND:N] [mode=exchange], two host FIFOs; fault injection for the
 * tests (pil.md): at block N the board takes a HardFault (KIND hardfault:
 * an undefined instruction) or hangs (KIND hang: a loop without end);
 * mode=exchange (./afm bench pil: the link's cost alone) answers every
 * STEP with FW_ERR_STATE and the models, without stepping the card.
 * Loop: read one request (fw_marshal.h: INIT, STEP, FIX), do it with
 * fw_card_*, answer with the result and the card's models
 * (fw_models_take). The board's CMSDK timer 0 (25 MHz, 40 ns a tick) is
 * read around fw_card_step_block; under qemu's -icount shift=0 one
 * instruction is one virtual ns, so ticks x 40 are instructions, to a
 * tick. A request arrives in one semihosting read where it fits
 * PIL_FIRST_READ (every block's does), its answer leaves in one write.
 * A request the board cannot read is answered with ERROR naming the field
 * and value, and the board exits 2; a fault exits 1 (startup.c).
 * No heap: every buffer below is static.
 */
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fw_card.h"
#include "fw_marshal.h"
#include "fw_models.h"

#define PIL_MAX_PARTICLES 1024
#define PIL_MAX_WIRES 256
#define PIL_MAX_LANDMARKS 256
#define PIL_MAX_TRENCH 16384
#define PIL_MAX_SAMPLES 8192
#define PIL_SCRATCH 256
#define PIL_REQUEST_BYTES (64u * 1024u + 24u * PIL_MAX_SAMPLES)
#define PIL_FIRST_READ 4096u   /* a block's request in one read (429 bytes at 20 samples) */
#define PIL_ANSWER_BYTES (64u * 1024u + 20u * PIL_MAX_TRENCH + 32u * (PIL_MAX_PARTICLES + PIL_MAX_WIRES))

/* CMSDK APB timer 0 of the mps2-an386: counts down at 25 MHz. */
#define TIMER0_CTRL (*(volatile uint32_t *)0x40000000u)
#define TIMER0_VALUE (*(volatile uint32_t *)0x40000004u)
#define TIMER0_RELOAD (*(volatile uint32_t *)0x40000008u)

static fw_card_t card;
static fw_card_config_t cfg;
static fw_card_particle_t cfg_particles[PIL_MAX_PARTICLES];
static fw_card_wire_t cfg_wires[PIL_MAX_WIRES];
static fw_card_landmark_t cfg_landmarks[PIL_MAX_LANDMARKS];
static fw_particle_t particle_store[PIL_MAX_PARTICLES];
static fw_wire_t wire_store[PIL_MAX_WIRES];
static fw_trench_point_t trench_store[PIL_MAX_TRENCH];
static fw_sample_out_t scratch[PIL_SCRATCH];
static fw_sample_in_t samples[PIL_MAX_SAMPLES];
static fw_models_particle_t model_particles[PIL_MAX_PARTICLES];
static fw_models_wire_t model_wires[PIL_MAX_WIRES];
static uint8_t request[PIL_REQUEST_BYTES];
static uint8_t answer[PIL_ANSWER_BYTES];
static bool running;
static int32_t blocks;                /* blocks stepped */
static int fault_kind;                /* 0 none, 1 hardfault, 2 hang */
static int32_t fault_block = -1;
static bool exchange_only;            /* mode=exchange: STEP answered without the card (./afm bench pil) */
/* the trench points the host holds, and the drift they were sent at */
static int32_t trench_sent;
static int32_t trench_sent_drift[2];

static uint32_t timer_now(void) { return TIMER0_VALUE; }

static bool read_all(int fd, uint8_t *p, uint32_t n)
{
    while (n > 0u) {
        const int got = read(fd, p, n);
        if (got <= 0) return false;
        p += got;
        n -= (uint32_t)got;
    }
    return true;
}

/* At least `least` bytes, at most `most`, into p: one semihosting read
 * when the host wrote the whole request at once (it does: one write, and a
 * request of a block is under the FIFO's atomic size); the count in *got. */
static bool read_some(int fd, uint8_t *p, uint32_t least, uint32_t most, uint32_t *got)
{
    *got = 0u;
    while (*got < least) {
        const int n = read(fd, p + *got, most - *got);
        if (n <= 0) return false;
        *got += (uint32_t)n;
    }
    return true;
}

static bool write_all(int fd, const uint8_t *p, uint32_t n)
{
    while (n > 0u) {
        const int put = write(fd, p, n);
        if (put <= 0) return false;
        p += put;
        n -= (uint32_t)put;
    }
    return true;
}

/* The models after a request, with the trench points the host lacks. */
static void put_models(fw_marshal_cursor_t *w)
{
    static fw_models_t m;
    m.particles = model_particles;
    m.particle_capacity = PIL_MAX_PARTICLES;
    m.wires = model_wires;
    m.wire_capacity = PIL_MAX_WIRES;
    if (!running || fw_models_take(&card, &m) != FW_OK) memset(&m, 0, sizeof m);
    int32_t from = trench_sent;
    if (m.trench_count < trench_sent || m.drift_pm[0] != trench_sent_drift[0] || m.drift_pm[1] != trench_sent_drift[1]) from = 0;
    fw_marshal_put_models_le(w, &m, from);
    trench_sent = m.trench_count;
    trench_sent_drift[0] = m.drift_pm[0];
    trench_sent_drift[1] = m.drift_pm[1];
}

static void do_init(fw_marshal_cursor_t *r, fw_marshal_cursor_t *w)
{
    const fw_marshal_config_arrays_t arr = {cfg_particles, PIL_MAX_PARTICLES, cfg_wires, PIL_MAX_WIRES,
                                            cfg_landmarks, PIL_MAX_LANDMARKS};
    int32_t cap[3] = {0, 0, 0};
    memset(&cfg, 0, sizeof cfg);
    fw_marshal_get_config_le(r, &cfg, &arr, cap);
    if (!fw_marshal_ok(r)) return;
    if (cap[0] > PIL_MAX_PARTICLES || cap[1] > PIL_MAX_WIRES || cap[2] > PIL_MAX_TRENCH || cap[0] < 0 || cap[1] < 0 || cap[2] < 0) {
        r->bad_field = "storage capacities (the board's: particles 1024, wires 256, trench points 16384)";
        r->bad_value = cap[0] > PIL_MAX_PARTICLES ? cap[0] : (cap[1] > PIL_MAX_WIRES ? cap[1] : cap[2]);
        return;
    }
    const fw_card_storage_t st = {cap[0] > 0 ? particle_store : NULL, cap[0], cap[1] > 0 ? wire_store : NULL, cap[1],
                                  cap[2] > 0 ? trench_store : NULL, cap[2], scratch, PIL_SCRATCH};
    fw_rule_t rule = FW_RULE_OK;
    running = fw_card_init(&card, &cfg, &st, &rule) == FW_OK;
    blocks = 0;
    trench_sent = 0;
    fw_marshal_put_i32_le(w, (int32_t)rule);
    put_models(w);
}

static void do_step(fw_marshal_cursor_t *r, fw_marshal_cursor_t *w, uint32_t t_request)
{
    fw_card_in_t in;
    fw_marshal_get_in_le(r, &in, samples, PIL_MAX_SAMPLES);
    if (!fw_marshal_ok(r)) return;
    fw_card_out_t out;
    memset(&out, 0, sizeof out);
    if (blocks++ == fault_block) {
        fputs(fault_kind == 1 ? "afm_board: fault injection: a HardFault\n" : "afm_board: fault injection: hanging\n", stderr);
        if (fault_kind == 1) __asm volatile(".short 0xde00");   /* udf #0 */
        for (;;) {
        }
    }
    const uint32_t t0 = timer_now();
    const fw_status_t s = running && !exchange_only ? fw_card_step_block(&card, &in, &out) : FW_ERR_STATE;
    const uint32_t t1 = timer_now();
    fw_marshal_put_i32_le(w, (int32_t)s);
    fw_marshal_put_out_le(w, &out);
    fw_marshal_put_u32_le(w, t0 - t1);   /* a down counter; modulo 2^32 */
    const uint32_t board_at = w->at;
    fw_marshal_put_u32_le(w, 0u);
    put_models(w);
    const uint32_t total = t_request - timer_now();
    w->w[board_at] = (uint8_t)(total & 0xFFu);   /* patched in place: the same layout as put_u32 */
    w->w[board_at + 1u] = (uint8_t)((total >> 8) & 0xFFu);
    w->w[board_at + 2u] = (uint8_t)((total >> 16) & 0xFFu);
    w->w[board_at + 3u] = (uint8_t)((total >> 24) & 0xFFu);
}

static void do_fix(fw_marshal_cursor_t *r, fw_marshal_cursor_t *w)
{
    fw_marshal_fix_t f;
    fw_marshal_get_fix_le(r, &f);
    if (!fw_marshal_ok(r)) return;
    fw_card_fix_out_t out;
    memset(&out, 0, sizeof out);
    fw_status_t s = FW_ERR_STATE;
    if (running) s = f.place ? fw_card_place(&card, f.object_id, f.scan_pm, &out) : fw_card_fix(&card, f.object_id, f.scan_pm, &out);
    fw_marshal_put_i32_le(w, (int32_t)s);
    fw_marshal_put_fix_out_le(w, &out);
    put_models(w);
}

/* One request read and answered; false when the link or a request is broken. */
static bool serve_one(int in_fd, int out_fd)
{
    fw_marshal_cursor_t r, w;
    uint32_t kind = 0, len = 0;
    /* the host sends one request and waits for its answer: nothing follows
     * a request in the FIFO, so reading up to PIL_FIRST_READ cannot take
     * the next one's bytes */
    uint32_t got = 0u;
    if (!read_some(in_fd, request, FW_MARSHAL_HEADER_BYTES, PIL_FIRST_READ, &got)) return false;
    const uint32_t t_request = timer_now();
    fw_marshal_reader_init(&r, request, FW_MARSHAL_HEADER_BYTES);
    fw_marshal_get_header_le(&r, &kind, &len);
    if (fw_marshal_ok(&r) && len > PIL_REQUEST_BYTES - FW_MARSHAL_HEADER_BYTES) {
        r.bad_field = "header.payload_bytes (above the board's buffer)";
        r.bad_value = (int32_t)len;
    }
    if (fw_marshal_ok(&r) && got > FW_MARSHAL_HEADER_BYTES + len) {
        r.bad_field = "header.payload_bytes (more bytes came than the header says)";
        r.bad_value = (int32_t)len;
    }
    if (fw_marshal_ok(&r) && got < FW_MARSHAL_HEADER_BYTES + len &&
        !read_all(in_fd, request + got, FW_MARSHAL_HEADER_BYTES + len - got))
        return false;
    if (fw_marshal_ok(&r)) fw_marshal_reader_init(&r, request + FW_MARSHAL_HEADER_BYTES, len);
    fw_marshal_writer_init(&w, answer, PIL_ANSWER_BYTES);
    fw_marshal_put_header_le(&w, kind, 0u);
    if (fw_marshal_ok(&r)) {
        if (kind == FW_MARSHAL_INIT) do_init(&r, &w);
        else if (kind == FW_MARSHAL_STEP) do_step(&r, &w, t_request);
        else if (kind == FW_MARSHAL_FIX) do_fix(&r, &w);
        else { r.bad_field = "header.kind"; r.bad_value = (int32_t)kind; }
    }
    const bool ok = fw_marshal_ok(&r) && fw_marshal_ok(&w);
    if (!ok) {
        static char text[200];
        snprintf(text, sizeof text, "afm_board: request %s: field %s, value %ld", fw_marshal_ok(&r) ? "answer" : "unreadable",
                 fw_marshal_ok(&r) ? w.bad_field : r.bad_field, (long)(fw_marshal_ok(&r) ? w.bad_value : r.bad_value));
        fputs(text, stderr);
        fputc('\n', stderr);
        fw_marshal_writer_init(&w, answer, PIL_ANSWER_BYTES);
        fw_marshal_put_header_le(&w, FW_MARSHAL_ERROR, 0u);
        fw_marshal_put_text_le(&w, text);
    }
    fw_marshal_patch_len_le(&w, 0u);
    return write_all(out_fd, answer, w.at) && ok;
}

/* One optional argument: fault=hardfault:N, fault=hang:N or
 * mode=exchange; false (and a line on stderr) for anything else. */
static bool take_option(const char *f)
{
    long n = -1;
    if (strcmp(f, "mode=exchange") == 0) {
        exchange_only = true;
        return true;
    }
    if (strncmp(f, "fault=hardfault:", 16) == 0) { fault_kind = 1; n = strtol(f + 16, NULL, 10); }
    else if (strncmp(f, "fault=hang:", 11) == 0) { fault_kind = 2; n = strtol(f + 11, NULL, 10); }
    if (n < 0) {
        fprintf(stderr, "afm_board: unknown argument '%s' (fault=hardfault:N, fault=hang:N or mode=exchange)\n", f);
        return false;
    }
    fault_block = (int32_t)n;
    return true;
}

int main(int argc, char **argv)
{
    if (argc < 3 || argc > 5) {
        fputs("afm_board: usage: afm_board TO_BOARD FROM_BOARD [fault=hardfault:N|hang:N] [mode=exchange] (semihosting arguments)\n", stderr);
        return 2;
    }
    for (int i = 3; i < argc; ++i)
        if (!take_option(argv[i])) return 2;
    const int in_fd = open(argv[1], O_RDONLY);
    const int out_fd = open(argv[2], O_WRONLY | O_TRUNC);
    if (in_fd < 0 || out_fd < 0) {
        fprintf(stderr, "afm_board: cannot open the link %s\n", in_fd < 0 ? argv[1] : argv[2]);
        return 2;
    }
    TIMER0_RELOAD = 0xFFFFFFFFu;
    TIMER0_VALUE = 0xFFFFFFFFu;
    TIMER0_CTRL = 1u;   /* enable, no interrupt */
    fputs("afm_board: the card is on the board; serving the link\n", stderr);
    while (serve_one(in_fd, out_fd)) {
    }
    fputs("afm_board: the link closed\n", stderr);
    return 2;
}
