#include "hand_input.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "process.hpp"

namespace afm {

HandInput::HandInput(const Scene &s, int fd) : scene_(s), fd_(fd), cmd_{s.start_nm(), s.op.load_nN, false}
{
    const int fl = fcntl(fd_, F_GETFL);
    if (fl >= 0) fcntl(fd_, F_SETFL, fl | O_NONBLOCK);
}

int HandInput::open_from_env()
{
    const char *path = std::getenv("AFM_HAND_FIFO");
    if (!path || !*path)
        throw InputError("operator: operator.mode browser takes the hand from the page: run it with ./afm run SCENE --view "
                         "(AFM_HAND_FIFO is not set)");
    const int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        throw InputError(std::string("operator: cannot open the page's hand, AFM_HAND_FIFO ") + path + ": " + std::strerror(errno));
    return fd;
}

void HandInput::poll()
{
    char buf[4096];
    while (true) {
        const ssize_t n = read(fd_, buf, sizeof buf);
        if (n <= 0) break;   // nothing more now (EAGAIN), or the server closed it
        partial_.append(buf, static_cast<std::size_t>(n));
        std::size_t nl;
        while ((nl = partial_.find('\n')) != std::string::npos) {
            Command c;
            if (nl <= kMaxLine && parse(partial_.substr(0, nl), &c)) {
                cmd_ = c;
                ++taken_;
            } else {
                ++refused_;
            }
            partial_.erase(0, nl + 1);
        }
        if (partial_.size() > kMaxLine) {   // a line too long: dropped up to its end
            partial_.clear();
            ++refused_;
        }
    }
}

bool HandInput::parse(const std::string &line, Command *c) const
{
    std::istringstream in(line);
    std::string word, rest;
    int engaged = -1;
    if (!(in >> word >> c->aim_nm.x >> c->aim_nm.y >> c->load_nN >> engaged) || word != "HAND" || (in >> rest)) return false;
    const double half = scene_.field_nm / 2;
    if (!std::isfinite(c->aim_nm.x) || !std::isfinite(c->aim_nm.y) || !std::isfinite(c->load_nN)) return false;
    if (std::fabs(c->aim_nm.x - scene_.field_center_nm.x) > half || std::fabs(c->aim_nm.y - scene_.field_center_nm.y) > half) return false;
    if (!(c->load_nN > 0 && c->load_nN <= kMaxLoad_nN) || (engaged != 0 && engaged != 1)) return false;
    c->engaged = engaged == 1;
    return true;
}

}  // namespace afm
