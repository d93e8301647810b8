// The card on its processor behind CardBackend (card_backend.hpp,
// docs/pil.md): afm_board.elf on an emulated mps2-an386 under
// qemu-system-arm -icount shift=0, each call sent over a host FIFO and
// answered over another (semihosting file I/O on the board), every struct
// marshalled by fw_marshal.c. The board answers every request within the
// deadline or the run ends naming it: it did not start, it exited (a
// fault exits 1), or it hung (no answer within kHangSeconds).
#include "card_backend.hpp"

extern "C" {
#include "fw_marshal.h"
}
#include "process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

#ifndef AFM_BOARD_ELF
#define AFM_BOARD_ELF ""
#endif

namespace afm {
namespace {

constexpr double kStartSeconds = 20;   // qemu's start and the first answer (a loaded machine)
constexpr double kHangSeconds = 2;     // then each answer
constexpr int kTickNs = 40;            // CMSDK timer 0 at 25 MHz; -icount shift=0: 1 instruction = 1 ns
constexpr double kBudgetHz = 168e6;    // the Cortex-M4 the budget is stated for
constexpr std::size_t kFirstReadBytes = 4096;   // an answer's first read, bytes (a block's: 191 with two particles)

std::string qemu_binary()
{
    const char *q = std::getenv("AFM_QEMU");   // another qemu-system-arm (tests name a missing one)
    if (q && *q) return q;
    const char *path = std::getenv("PATH");
    std::string p = path ? path : "/usr/bin:/bin";
    for (std::size_t at = 0; at <= p.size();) {
        const std::size_t end = std::min(p.find(':', at), p.size());
        const std::string cand = p.substr(at, end - at) + "/qemu-system-arm";
        if (access(cand.c_str(), X_OK) == 0) return cand;
        at = end + 1;
    }
    return "";
}

std::string tail_of(const std::string &file, std::size_t bytes = 400)
{
    std::ifstream f(file, std::ios::binary);
    std::string s((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (s.size() > bytes) s = "..." + s.substr(s.size() - bytes);
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    for (char &c : s)
        if (c == '\n') c = '|';
    return s.empty() ? "(none)" : s;
}

struct Stats {
    std::vector<double> v;
    nlohmann::json json(double scale = 1) const
    {
        if (v.empty()) return nullptr;
        std::vector<double> s = v;
        std::sort(s.begin(), s.end());
        double sum = 0;
        for (double x : s) sum += x;
        return {{"median", s[s.size() / 2] * scale}, {"p99", s[std::min(s.size() - 1, s.size() * 99 / 100)] * scale},
                {"worst", s.back() * scale}, {"mean", sum / static_cast<double>(s.size()) * scale}, {"n", s.size()}};
    }
};

class BoardCard final : public CardBackend {
public:
    explicit BoardCard(const CardBackendOptions &o) : o_(o) { start(); }
    ~BoardCard() override { stop(); }

    fw_rule_t init(const fw_card_config_t &cfg, const fw_card_storage_t &st) override;
    fw_status_t step_block(const fw_card_in_t &in, fw_card_out_t *out) override;
    fw_status_t fix(bool place, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out) override;
    const fw_models_t &models() const override { return models_; }
    nlohmann::json report() const override;
    void check_alive() override;

private:
    CardBackendOptions o_;
    std::string dir_, elf_, log_, qemu_;
    pid_t pid_ = -1;
    int to_ = -1, from_ = -1;
    int64_t blocks_ = 0;
    std::vector<uint8_t> req_, ans_;
    fw_models_t models_{};
    std::vector<fw_models_particle_t> particles_;
    std::vector<fw_models_wire_t> wires_;
    std::vector<fw_trench_point_t> trench_;
    Stats step_insn_, board_insn_, round_trip_us_, bytes_to_, bytes_from_;   // per block
    double start_ms_ = 0;   // from qemu's start to the answer to INIT
    bool exchange_only_ = false;   // AFM_BOARD_MODE=exchange: blocks answered without the card

    void start();
    void stop();
    [[noreturn]] void fail(const std::string &what);
    void fail_if_exited(const std::string &at);
    void exchange(uint32_t kind, double deadline_s, fw_marshal_cursor_t *answer);
    void read_models(fw_marshal_cursor_t *r);
    void check(const fw_marshal_cursor_t &r, const char *what);
};

void BoardCard::fail(const std::string &what)
{
    std::string msg = "the card's board (" + elf_ + " on qemu-system-arm -M mps2-an386) " + what + "; its last output: " + tail_of(log_) +
                      " (log: " + log_ + ")";
    stop();
    throw BoardError(msg);
}

void BoardCard::start()
{
    elf_ = o_.board_elf.empty() ? AFM_BOARD_ELF : o_.board_elf;
    qemu_ = qemu_binary();
    if (qemu_.empty() || access(qemu_.c_str(), X_OK) != 0)
        throw BoardError("the card's board cannot start: qemu-system-arm " + (qemu_.empty() ? std::string("not found on PATH") : qemu_ + " not found") +
                         " (install it: ./afm setup)");
    struct stat sb{};
    if (elf_.empty() || stat(elf_.c_str(), &sb) != 0 || !S_ISREG(sb.st_mode))
        throw BoardError("the card's board cannot start: no board image at '" + elf_ + "' (build it: ./afm build)");
    char tmpl[] = "/tmp/afm-board-XXXXXX";
    if (!mkdtemp(tmpl)) throw BoardError(std::string("the card's board: cannot make the link's folder: ") + std::strerror(errno));
    dir_ = tmpl;
    log_ = o_.board_log.empty() ? dir_ + "/board.log" : o_.board_log;
    const std::string to = dir_ + "/to_board", from = dir_ + "/from_board";
    if (mkfifo(to.c_str(), 0600) != 0 || mkfifo(from.c_str(), 0600) != 0)
        throw BoardError("the card's board: cannot make the link's FIFOs in " + dir_ + ": " + std::strerror(errno));
    // read and write both ends ourselves: neither open waits for the board
    to_ = open(to.c_str(), O_RDWR | O_CLOEXEC);
    from_ = open(from.c_str(), O_RDWR | O_CLOEXEC);
    const int logfd = open(log_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (to_ < 0 || from_ < 0 || logfd < 0) throw BoardError("the card's board: cannot open its link or log " + log_ + ": " + std::strerror(errno));
    // AFM_BOARD_FAULT=hardfault:N|hang:N: the board faults or hangs at block N (the tests' fault injection)
    const char *fault = std::getenv("AFM_BOARD_FAULT");
    std::string fault_arg = fault && *fault ? std::string(",arg=fault=") + fault : "";
    // AFM_BOARD_MODE=exchange: the board answers each block without stepping the card (./afm bench pil: the link alone)
    const char *mode = std::getenv("AFM_BOARD_MODE");
    if (mode && *mode) {
        if (std::string(mode) != "exchange") throw BoardError("the card's board: AFM_BOARD_MODE='" + std::string(mode) + "': only 'exchange' is known");
        fault_arg += ",arg=mode=exchange";
        exchange_only_ = true;
    }
    const std::vector<std::string> args = {qemu_, "-M", "mps2-an386", "-nographic", "-monitor", "none", "-icount", "shift=0,sleep=off",
                                           "-semihosting-config", "enable=on,target=native,arg=afm_board,arg=" + to + ",arg=" + from + fault_arg,
                                           "-kernel", elf_};
    const pid_t node = getpid();
    pid_ = fork();
    if (pid_ == 0) {
        if (!afm::bind_to_parent(node)) _exit(127);   // the board goes when its node goes (process.hpp), and never outlives one already gone
        const int devnull = open("/dev/null", O_RDONLY);
        dup2(devnull, 0);
        dup2(logfd, 1);
        dup2(logfd, 2);
        std::vector<char *> argv;
        for (const auto &a : args) argv.push_back(const_cast<char *>(a.c_str()));
        argv.push_back(nullptr);
        execv(argv[0], argv.data());
        _exit(127);
    }
    close(logfd);
    if (pid_ < 0) throw BoardError(std::string("the card's board: fork failed: ") + std::strerror(errno));
}

void BoardCard::stop()
{
    if (to_ >= 0) close(to_);   // the board reads the end of its link and exits
    to_ = -1;
    if (pid_ > 0) {
        int st = 0;
        const auto t0 = std::chrono::steady_clock::now();
        while (waitpid(pid_, &st, WNOHANG) == 0) {
            if (std::chrono::steady_clock::now() - t0 > std::chrono::milliseconds(500)) {
                kill(pid_, SIGKILL);
                waitpid(pid_, &st, 0);
                break;
            }
            usleep(2000);
        }
        pid_ = -1;
    }
    if (from_ >= 0) close(from_);
    from_ = -1;
    if (!dir_.empty()) {
        unlink((dir_ + "/to_board").c_str());
        unlink((dir_ + "/from_board").c_str());
        if (o_.board_log.empty()) unlink(log_.c_str());
        rmdir(dir_.c_str());
        dir_.clear();
    }
}

// Fails naming how the board's emulator ended ("exited (signal 9) at AT")
// when it has; returns when it still runs.
void BoardCard::fail_if_exited(const std::string &at)
{
    int st = 0;
    if (pid_ <= 0 || waitpid(pid_, &st, WNOHANG) != pid_) return;
    pid_ = -1;
    fail("exited (" + std::string(WIFEXITED(st) ? "status " + std::to_string(WEXITSTATUS(st)) : "signal " + std::to_string(WTERMSIG(st))) +
         ") at " + at);
}

void BoardCard::check_alive() { fail_if_exited("block " + std::to_string(blocks_) + ", before the host sent it"); }

// Sends req_ (a whole message) and reads the answer into ans_, within the
// deadline; *answer reads its payload. The board's death or silence fails.
void BoardCard::exchange(uint32_t kind, double deadline_s, fw_marshal_cursor_t *answer)
{
    const std::string at = kind == FW_MARSHAL_STEP ? "block " + std::to_string(blocks_) : kind == FW_MARSHAL_INIT ? "its start" : "a fix after block " + std::to_string(blocks_ - 1);
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t put = 0; put < req_.size();) {
        const ssize_t n = write(to_, req_.data() + put, req_.size() - put);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) fail("could not be sent " + at + ": " + std::strerror(errno));
        put += static_cast<std::size_t>(n);
    }
    // The board writes an answer whole and nothing after it (one request
    // at a time): read as much as has come, usually all of it at once.
    std::size_t got = 0, want = FW_MARSHAL_HEADER_BYTES;
    ans_.resize(std::max<std::size_t>(ans_.size(), kFirstReadBytes));
    bool header = true;
    while (got < want) {
        pollfd p{from_, POLLIN, 0};
        const int r = poll(&p, 1, 50);
        if (r > 0) {
            const ssize_t n = read(from_, ans_.data() + got, ans_.size() - got);
            if (n > 0) got += static_cast<std::size_t>(n);
        }
        if (r == 0) fail_if_exited(at);
        const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (r == 0 && waited > deadline_s) {
            kill(pid_, SIGKILL);
            fail("hung: no answer to " + at + " within " + std::to_string(static_cast<int>(deadline_s)) + " s");
        }
        if (header && got >= want) {
            fw_marshal_cursor_t h;
            uint32_t k = 0, len = 0;
            fw_marshal_reader_init(&h, ans_.data(), FW_MARSHAL_HEADER_BYTES);
            fw_marshal_get_header_le(&h, &k, &len);
            if (!fw_marshal_ok(&h) || (k != kind && k != FW_MARSHAL_ERROR) || len > (64u << 20))
                fail("answered " + at + " with a bad header (" + std::string(h.bad_field ? h.bad_field : "header.kind") + ")");
            header = false;
            want += len;
            if (ans_.size() < want) ans_.resize(want);
            if (k == FW_MARSHAL_ERROR) kind = FW_MARSHAL_ERROR;
        }
    }
    if (got > want) fail("answered " + at + " with " + std::to_string(got - want) + " bytes more than its header says");
    ans_.resize(want);
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    if (kind == FW_MARSHAL_INIT) start_ms_ = us * 1e-3;   // qemu's start with it
    if (kind == FW_MARSHAL_STEP) {
        round_trip_us_.v.push_back(us);
        bytes_to_.v.push_back(static_cast<double>(req_.size()));
        bytes_from_.v.push_back(static_cast<double>(ans_.size()));
    }
    fw_marshal_reader_init(answer, ans_.data() + FW_MARSHAL_HEADER_BYTES, static_cast<uint32_t>(ans_.size() - FW_MARSHAL_HEADER_BYTES));
    if (kind == FW_MARSHAL_ERROR) {
        char text[256];
        fw_marshal_get_text_le(answer, text, sizeof text);
        fail(std::string("refused ") + at + ": " + text);
    }
}

void BoardCard::check(const fw_marshal_cursor_t &r, const char *what)
{
    if (fw_marshal_ok(&r) && r.at == r.len) return;
    fail(std::string("sent an answer to ") + what + " the host cannot read: " +
         (r.bad_field ? std::string("field ") + r.bad_field + ", value " + std::to_string(r.bad_value)
                      : std::to_string(r.len - r.at) + " bytes left over"));
}

void BoardCard::read_models(fw_marshal_cursor_t *r)
{
    fw_marshal_get_models_le(r, &models_, trench_.data(), static_cast<int32_t>(trench_.size()));
}

// Begins a request of this kind in req_.
static fw_marshal_cursor_t begin(std::vector<uint8_t> &req, std::size_t cap, uint32_t kind)
{
    req.resize(cap);
    fw_marshal_cursor_t w;
    fw_marshal_writer_init(&w, req.data(), static_cast<uint32_t>(req.size()));
    fw_marshal_put_header_le(&w, kind, 0u);
    return w;
}

static void finish(std::vector<uint8_t> &req, fw_marshal_cursor_t *w)
{
    if (!fw_marshal_ok(w)) throw std::logic_error(std::string("fw_marshal: the request does not fit its buffer at ") + w->bad_field);
    fw_marshal_patch_len_le(w, 0u);
    req.resize(w->at);
}

fw_rule_t BoardCard::init(const fw_card_config_t &cfg, const fw_card_storage_t &st)
{
    particles_.resize(static_cast<std::size_t>(std::max(cfg.n_particles, 0)));
    wires_.resize(static_cast<std::size_t>(std::max(cfg.n_wires, 0)));
    trench_.resize(static_cast<std::size_t>(std::max(st.trench_capacity, 0)));
    models_.particles = particles_.data();
    models_.particle_capacity = cfg.n_particles;
    models_.wires = wires_.data();
    models_.wire_capacity = cfg.n_wires;
    const std::size_t cap = 4096 + 32 * static_cast<std::size_t>(cfg.n_particles + cfg.n_wires + cfg.n_landmarks);
    fw_marshal_cursor_t w = begin(req_, cap, FW_MARSHAL_INIT);
    fw_marshal_put_config_le(&w, &cfg, &st);
    finish(req_, &w);
    fw_marshal_cursor_t r;
    exchange(FW_MARSHAL_INIT, kStartSeconds, &r);
    const int32_t rule = fw_marshal_get_i32_le(&r, "init.rule");
    read_models(&r);
    check(r, "its start");
    return static_cast<fw_rule_t>(rule);
}

fw_status_t BoardCard::step_block(const fw_card_in_t &in, fw_card_out_t *out)
{
    fw_marshal_cursor_t w = begin(req_, 64 + 24 * static_cast<std::size_t>(std::max(in.n, 0)), FW_MARSHAL_STEP);
    fw_marshal_put_in_le(&w, &in);
    finish(req_, &w);
    fw_marshal_cursor_t r;
    exchange(FW_MARSHAL_STEP, kHangSeconds, &r);
    const int32_t status = fw_marshal_get_i32_le(&r, "step.status");
    fw_marshal_get_out_le(&r, out);
    const uint32_t step_ticks = fw_marshal_get_u32_le(&r, "step.step_ticks");
    const uint32_t board_ticks = fw_marshal_get_u32_le(&r, "step.board_ticks");
    read_models(&r);
    check(r, ("block " + std::to_string(blocks_)).c_str());
    step_insn_.v.push_back(static_cast<double>(step_ticks) * kTickNs);
    board_insn_.v.push_back(static_cast<double>(board_ticks) * kTickNs);
    ++blocks_;
    return static_cast<fw_status_t>(status);
}

fw_status_t BoardCard::fix(bool place, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out)
{
    fw_marshal_cursor_t w = begin(req_, 64, FW_MARSHAL_FIX);
    const fw_marshal_fix_t f = {place, object_id, {scan_pm[0], scan_pm[1]}};
    fw_marshal_put_fix_le(&w, &f);
    finish(req_, &w);
    fw_marshal_cursor_t r;
    exchange(FW_MARSHAL_FIX, kHangSeconds, &r);
    const int32_t status = fw_marshal_get_i32_le(&r, "fix.status");
    fw_marshal_get_fix_out_le(&r, out);
    read_models(&r);
    check(r, "a fix");
    return static_cast<fw_status_t>(status);
}

nlohmann::json BoardCard::report() const
{
    const double spb = std::max(o_.samples_per_block, 1);
    const double cycles = kBudgetHz / o_.block_hz;   // a 168 MHz core's cycles per block
    nlohmann::json j = {{"firmware", "qemu"},
                        {"machine", "mps2-an386 (Cortex-M4), qemu-system-arm -icount shift=0,sleep=off"},
                        {"elf", elf_},
                        {"mode", exchange_only_ ? "exchange (AFM_BOARD_MODE: the card not stepped, the link's cost alone)" : "card"},
                        {"blocks", blocks_},
                        {"instructions_per_block", step_insn_.json()},
                        {"instructions_per_sample", step_insn_.json(1.0 / spb)},
                        {"instructions_resolution", kTickNs},
                        {"board_instructions_per_request", board_insn_.json()},
                        {"round_trip_us", round_trip_us_.json()},
                        {"first_round_trip_us", round_trip_us_.v.empty() ? nlohmann::json(nullptr) : nlohmann::json(round_trip_us_.v[0])},
                        {"start_ms", start_ms_},
                        {"bytes_to_board", bytes_to_.json()},
                        {"bytes_from_board", bytes_from_.json()}};
    if (!step_insn_.v.empty()) {
        const nlohmann::json s = step_insn_.json();
        const double med = s["median"].get<double>(), worst = s["worst"].get<double>();
        j["budget"] = {{"cpu_hz", kBudgetHz},
                       {"block_hz", o_.block_hz},
                       {"cycles_per_block", cycles},
                       {"assumption", "cycles = instructions x CPI, CPI 1 to 2 on a Cortex-M4 (1: every instruction single-cycle; "
                                      "2: loads, taken branches and flash wait states at 168 MHz); icount counts instructions, not cycles"},
                       {"fraction_median_cpi1", med / cycles},
                       {"fraction_worst_cpi1", worst / cycles},
                       {"fraction_worst_cpi2", 2 * worst / cycles}};
    }
    return j;
}

}  // namespace

std::unique_ptr<CardBackend> make_board_backend(const CardBackendOptions &o) { return std::make_unique<BoardCard>(o); }

}  // namespace afm
