#include "run_folder.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "run_record.hpp"

namespace afm::launch {

namespace fs = std::filesystem;

namespace {

bool only_a_lock(const fs::path &dir)
{
    for (const auto &e : fs::directory_iterator(dir))
        if (e.path().filename() != RunFolder::kLockName) return false;
    return true;
}

}  // namespace

// The launcher ended (however the run did): the lock's file goes, removed
// while still held, so no run can take the folder between the removal and
// the release (one that opened the file before is refused, or finds it
// removed once it holds it: lock()).
RunFolder::~RunFolder()
{
    if (lock_fd_ < 0) return;
    if (unlink((fs::path(dir_) / kLockName).c_str()) != 0 && errno != ENOENT)
        std::fprintf(stderr, "afm_launch: warning: cannot remove the lock %s/%s: %s\n", dir_.c_str(), kLockName, std::strerror(errno));
    close(lock_fd_);
}

int RunFolder::check() const
{
    const fs::path dir = dir_;
    std::error_code ec;
    if (dir.empty() || !fs::exists(dir, ec)) return -1;
    if (!fs::is_directory(fs::symlink_status(dir, ec)) ||
        (!only_a_lock(dir) && !fs::exists(dir / "run.json", ec) && !fs::exists(dir / "bus.lcmlog", ec))) {
        std::fprintf(stderr, "afm_launch: output folder %s exists and holds something that is not a run; choose another --out\n", dir_.c_str());
        return 2;
    }
    if (lock_fd_ >= 0) return -1;   // this run holds it already
    const std::string path = (dir / kLockName).string();
    const int fd = open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return -1;
    struct stat st {};
    const bool busy = fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && flock(fd, LOCK_SH | LOCK_NB) != 0;
    if (busy) say_in_use(fd, path);
    close(fd);
    return busy ? 2 : -1;
}

int RunFolder::take()
{
    const fs::path dir = dir_;
    // the lock first: a run under way is named as such, whatever it has written yet
    if (fs::exists(dir) && fs::is_directory(dir))
        if (const int code = lock(); code >= 0) return code;
    if (const int code = check(); code >= 0) return code;
    fs::create_directories(dir);
    if (lock_fd_ < 0)
        if (const int code = lock(); code >= 0) return code;
    for (const auto &old : run_outputs()) fs::remove_all(dir / old);
    fs::create_directories(dir / "logs");
    fs::create_directories(dir / "frames");
    for (const auto &e : fs::directory_iterator(dir))
        if (e.path().filename().string().rfind("scan_local_", 0) == 0) fs::remove(e.path());
    return -1;
}

// "in use by another run", naming the pid its lock (fd, at path) holds.
void RunFolder::say_in_use(int fd, const std::string &path) const
{
    char holder[64] = {0};
    const ssize_t n = pread(fd, holder, sizeof holder - 1, 0);
    std::string who(holder, n > 0 ? static_cast<std::size_t>(n) : 0);
    while (!who.empty() && (who.back() == '\n' || who.back() == ' ')) who.pop_back();
    std::fprintf(stderr, "afm_launch: output folder %s is in use by another run (%s; its lock %s); choose another --out\n", dir_.c_str(),
                 who.empty() ? "pid unknown" : who.c_str(), path.c_str());
}

// -1 when the folder is ours now; else the exit code, said.
int RunFolder::lock()
{
    const fs::path dir = dir_;
    const std::string path = (dir / kLockName).string();
    // held, the file must still be the folder's: a launcher that ended
    // removed it (~RunFolder) after this one opened it; then open anew
    for (int tries = 0; lock_fd_ < 0; ++tries) {
        const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
        if (fd < 0) {
            std::fprintf(stderr, "afm_launch: cannot lock the output folder %s: %s\n", dir_.c_str(), std::strerror(errno));
            return 2;
        }
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            say_in_use(fd, path);
            close(fd);
            return 2;
        }
        struct stat held {}, named {};
        if (fstat(fd, &held) == 0 && lstat(path.c_str(), &named) == 0 && held.st_dev == named.st_dev && held.st_ino == named.st_ino)
            lock_fd_ = fd;
        else if (close(fd), tries >= 10) {
            std::fprintf(stderr, "afm_launch: cannot lock the output folder %s: its lock %s was removed under it 10 times\n", dir_.c_str(), path.c_str());
            return 2;
        }
    }
    // the record of the last run in this folder: "pid N" while it ran; the
    // file is removed when its launcher ends, so a "pid N" left behind is a
    // launcher that never ended (SIGKILL, a crash), and the lock, now ours,
    // says it is gone
    char last[64] = {0};
    const ssize_t got = pread(lock_fd_, last, sizeof last - 1, 0);
    const std::string was(last, got > 0 ? static_cast<std::size_t>(got) : 0);
    if (was.rfind("pid ", 0) == 0)
        std::fprintf(stderr, "afm_launch: the last run in %s was interrupted: its launcher (%s) ended without finishing it%s; this run replaces it\n",
                     dir_.c_str(), was.substr(0, was.find('\n')).c_str(), fs::exists(dir / "run.json") ? "" : " and left no run.json");
    const std::string me = "pid " + std::to_string(getpid()) + "\n";
    if (ftruncate(lock_fd_, 0) != 0 || pwrite(lock_fd_, me.data(), me.size(), 0) != static_cast<ssize_t>(me.size()))
        std::fprintf(stderr, "afm_launch: warning: cannot write the lock %s's pid: %s\n", path.c_str(), std::strerror(errno));
    return -1;
}

}  // namespace afm::launch
