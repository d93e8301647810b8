// The run's folder (--out): whether a run may take it (none yet, an earlier
// run's, or new), its lock for the run's life, and making it ready. The lock
// is flock on OUT/.afm-run.lock, which names the run's pid: a second run
// into the folder is refused at once, naming the one that holds it. The
// lock goes with this process, however it ends; the launcher that ends
// removes the file while it still holds it (~RunFolder), so a run's folder
// keeps no lock, and a "pid N" found by the next launcher is a run whose
// launcher was killed (its processes went with it: children.hpp), said in
// one line.
#pragma once

#include <string>

namespace afm::launch {

class RunFolder {
public:
    explicit RunFolder(std::string dir) : dir_(std::move(dir)) {}
    ~RunFolder();
    RunFolder(const RunFolder &) = delete;
    RunFolder &operator=(const RunFolder &) = delete;

    // -1 when the folder is one a run may take (none, a run's, or new);
    // else 2, said. A run under way in it (its lock held) is named; the lock
    // is opened read-only, no link followed, never created (--check asks
    // only this, before run/in_netns.sh hands the folder to the run's user).
    int check() const;

    // Takes the folder: locked, an earlier run's outputs removed, logs/ and
    // frames/ made. -1, or the exit code, said; throws filesystem_error.
    int take();

    static constexpr const char *kLockName = ".afm-run.lock";

private:
    std::string dir_;
    int lock_fd_ = -1;
    void say_in_use(int fd, const std::string &path) const;
    int lock();
};

}  // namespace afm::launch
