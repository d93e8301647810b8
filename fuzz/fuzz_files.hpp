// What the harnesses that read files share: a private folder per process
// (under $TMPDIR or /tmp, removed at exit) and a file in it rewritten with
// each input. libFuzzer runs one input at a time in one thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>

namespace afm_fuzz {

// Where a harness reports: stderr as it was at start, before libFuzzer's
// -close_fd_mask closes the target's own (tools/fuzz.sh runs with it).
inline const int kReportFd = dup(2);

// Stops the run as a crash: a property the code promises does not hold.
[[noreturn]] inline void broken(const char *what, const std::string &detail = "")
{
    dprintf(kReportFd, "fuzz: broken promise: %s%s%s\n", what, detail.empty() ? "" : ": ", detail.c_str());
    std::abort();
}

class Folder {
public:
    explicit Folder(const char *name)
    {
        const char *tmp = std::getenv("TMPDIR");
        std::string t = std::string(tmp && *tmp ? tmp : "/tmp") + "/afm-fuzz-" + name + "-XXXXXX";
        if (!mkdtemp(t.data())) broken("cannot make a folder under TMPDIR");
        path_ = t;
    }
    ~Folder()
    {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    Folder(const Folder &) = delete;
    Folder &operator=(const Folder &) = delete;

    const std::string &path() const { return path_; }
    std::string file(const std::string &name) const { return path_ + "/" + name; }

    // Writes `size` bytes as the file `name` (replacing it); returns its path.
    std::string write(const std::string &name, const uint8_t *data, std::size_t size, const char *mode = "wb") const
    {
        const std::string p = file(name);
        std::FILE *f = std::fopen(p.c_str(), mode);
        if (!f) broken("cannot write in the harness's folder");
        if (size && std::fwrite(data, 1, size, f) != size) broken("short write in the harness's folder");
        if (std::fclose(f) != 0) broken("cannot close a file in the harness's folder");
        return p;
    }
    std::string write(const std::string &name, const std::string &text) const
    {
        return write(name, reinterpret_cast<const uint8_t *>(text.data()), text.size());
    }

private:
    std::string path_;
};

}  // namespace afm_fuzz
