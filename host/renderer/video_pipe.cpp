#include "video_pipe.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

extern char **environ;

namespace afm {

namespace {

constexpr const char *kEncoder = "libx264";

// Starts argv with stdin from in_fd (or /dev/null when -1) and stdout into
// out_fd (or our stderr when -1); the child's pid, or -1 (errno set).
// The child runs in a process group of its own: a signal sent to the
// renderer's group (a Ctrl-C, the launcher stopping a run) does not stop
// the encoder mid-file; it ends when its input does (close(), or the
// renderer's death), and finishes the file then.
pid_t spawn(const std::vector<std::string> &argv, int in_fd, int out_fd, int close_fd)
{
    std::vector<char *> args;
    for (const std::string &a : argv) args.push_back(const_cast<char *>(a.c_str()));
    args.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    if (in_fd >= 0) posix_spawn_file_actions_adddup2(&fa, in_fd, STDIN_FILENO);
    else posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&fa, out_fd >= 0 ? out_fd : STDERR_FILENO, STDOUT_FILENO);
    if (close_fd >= 0) posix_spawn_file_actions_addclose(&fa, close_fd);
    posix_spawnattr_t at;
    posix_spawnattr_init(&at);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&at, 0);
    pid_t pid = -1;
    const int rc = posix_spawnp(&pid, args[0], &fa, &at, args.data(), environ);
    posix_spawnattr_destroy(&at);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) {
        errno = rc;
        return -1;
    }
    return pid;
}

// Whether `ffmpeg -h encoder=libx264` describes the encoder (its first line
// "Encoder libx264 ..."); *why otherwise.
bool has_encoder(const std::string &ffmpeg, std::string *why)
{
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0) {
        *why = std::string("pipe: ") + std::strerror(errno);
        return false;
    }
    const pid_t pid = spawn({ffmpeg, "-hide_banner", "-h", std::string("encoder=") + kEncoder}, -1, p[1], p[0]);
    const int spawn_errno = errno;
    ::close(p[1]);
    std::string text;
    char buf[256];
    for (ssize_t n; pid > 0 && (n = read(p[0], buf, sizeof buf)) > 0 && text.size() < 4096;) text.append(buf, static_cast<std::size_t>(n));
    ::close(p[0]);
    if (pid < 0) {
        *why = "cannot start " + ffmpeg + ": " + std::strerror(spawn_errno);
        return false;
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        *why = ffmpeg + " is not there or failed (exit status " + std::to_string(status) + ")";
        return false;
    }
    if (text.rfind(std::string("Encoder ") + kEncoder, 0) != 0) {
        *why = ffmpeg + " has no " + kEncoder + " encoder";
        return false;
    }
    return true;
}

std::string fps_text(double fps)
{
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", fps);
    return b;
}

}  // namespace

std::string VideoPipe::program()
{
    const char *e = std::getenv("AFM_FFMPEG");
    return e && *e ? e : "ffmpeg";
}

VideoPipe::~VideoPipe()
{
    std::string ignored;
    if (is_open()) close(&ignored);
}

namespace {

// Waits (at most `limit`) until process pid blocks in read() on its stdin
// (/proc/PID/syscall: "NR_read 0x0 ..."): ffmpeg has loaded its 200-odd
// libraries and waits for the first frame. False if it ended or the file
// cannot be read (another kernel): the caller goes on regardless.
bool wait_until_reading_stdin(pid_t pid, std::chrono::milliseconds limit)
{
    const std::string want = std::to_string(SYS_read) + " 0x0 ";
    const std::string file = "/proc/" + std::to_string(pid) + "/syscall";
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
        std::ifstream f(file);
        std::string line;
        if (!f || !std::getline(f, line)) return false;
        if (line.compare(0, want.size(), want) == 0) return true;
        siginfo_t info{};
        if (waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) != 0 || info.si_pid != 0)
            return false;   // it ended (left for close() to reap, with its status)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return false;
}

}  // namespace

bool VideoPipe::open(const std::string &path, int width_px, int height_px, double fps, std::string *why)
{
    const std::string ffmpeg = program();
    if (!has_encoder(ffmpeg, why)) return false;
    // A dead encoder makes write() fail with EPIPE on this thread, not kill us.
    sigset_t pipe_sig;
    sigemptyset(&pipe_sig);
    sigaddset(&pipe_sig, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe_sig, nullptr);
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0) {
        *why = std::string("pipe: ") + std::strerror(errno);
        return false;
    }
    // yuv420p (what browsers decode) needs even sides: an odd one is padded.
    const std::vector<std::string> argv = {ffmpeg, "-hide_banner", "-loglevel", "error", "-nostdin", "-y",
                                           "-f", "rawvideo", "-pix_fmt", "bgr24",
                                           "-s", std::to_string(width_px) + "x" + std::to_string(height_px),
                                           "-r", fps_text(fps), "-i", "pipe:0",
                                           "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                                           "-c:v", kEncoder, "-threads", "1", "-preset", "veryfast", "-crf", "18", "-pix_fmt", "yuv420p",
                                           "-movflags", "+faststart", "-f", "mp4", path};
    pid_ = spawn(argv, p[0], -1, p[1]);
    const int spawn_errno = errno;
    ::close(p[0]);
    if (pid_ < 0) {
        ::close(p[1]);
        *why = "cannot start " + ffmpeg + ": " + std::strerror(spawn_errno);
        return false;
    }
    fd_ = p[1];
    width_ = width_px;
    height_ = height_px;
    wait_until_reading_stdin(pid_, std::chrono::milliseconds(2000));
    return true;
}

bool VideoPipe::write(const cv::Mat &frame)
{
    if (fd_ < 0 || frame.type() != CV_8UC3 || frame.cols != width_ || frame.rows != height_) return false;
    const cv::Mat m = frame.isContinuous() ? frame : frame.clone();
    const char *p = reinterpret_cast<const char *>(m.data);
    std::size_t left = m.total() * m.elemSize();
    while (left > 0) {
        const ssize_t n = ::write(fd_, p, left);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        p += n;
        left -= static_cast<std::size_t>(n);
    }
    return true;
}

bool VideoPipe::close(std::string *why)
{
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    if (pid_ <= 0) return true;
    int status = 0;
    rusage ru{};
    pid_t r;
    do r = wait4(pid_, &status, 0, &ru);
    while (r < 0 && errno == EINTR);
    pid_ = -1;
    child_cpu_s_ = ru.ru_utime.tv_sec + ru.ru_utime.tv_usec * 1e-6 + ru.ru_stime.tv_sec + ru.ru_stime.tv_usec * 1e-6;
    if (r < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        *why = program() + " ended with status " + std::to_string(status) + " writing the video";
        return false;
    }
    return true;
}

}  // namespace afm
