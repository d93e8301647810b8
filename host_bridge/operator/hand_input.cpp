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
            if (nl > kMaxLine || !take_line(partial_.substr(0, nl))) ++refused_;
            partial_.erase(0, nl + 1);
        }
        if (partial_.size() > kMaxLine) {   // a line too long: dropped up to its end
            partial_.clear();
            ++refused_;
        }
    }
}

bool HandInput::take_line(const std::string &line)
{
    Command c;
    ScanAsk a;
    if (parse(line, &c)) {
        cmd_ = c;
        ++taken_;
        return true;
    }
    if (parse_scan(line, &a)) {
        scan_ = a;
        scan_pending_ = true;
        ++scans_asked_;
        return true;
    }
    return false;
}

bool HandInput::take_scan(ScanAsk *s)
{
    if (!scan_pending_) return false;
    *s = scan_;
    scan_pending_ = false;
    return true;
}

bool HandInput::in_field(Vec2 p_nm) const
{
    const double half = scene_.field_nm / 2;
    return std::isfinite(p_nm.x) && std::isfinite(p_nm.y) && std::fabs(p_nm.x - scene_.field_center_nm.x) <= half &&
           std::fabs(p_nm.y - scene_.field_center_nm.y) <= half;
}

bool HandInput::parse_scan(const std::string &line, ScanAsk *s) const
{
    std::istringstream in(line);
    std::string word, rest;
    if (!(in >> word >> s->center_nm.x >> s->center_nm.y >> s->size_nm) || word != "SCAN" || (in >> rest)) return false;
    const double min_nm = kMinScanPx * scene_.field_nm / scene_.out.image_px;
    return in_field(s->center_nm) && std::isfinite(s->size_nm) && s->size_nm >= min_nm && s->size_nm <= scene_.field_nm;
}

bool HandInput::parse(const std::string &line, Command *c) const
{
    std::istringstream in(line);
    std::string word, rest;
    int engaged = -1;
    if (!(in >> word >> c->aim_nm.x >> c->aim_nm.y >> c->load_nN >> engaged) || word != "HAND" || (in >> rest)) return false;
    if (!in_field(c->aim_nm) || !std::isfinite(c->load_nN)) return false;
    if (!(c->load_nN > 0 && c->load_nN <= kMaxLoad_nN) || (engaged != 0 && engaged != 1)) return false;
    c->engaged = engaged == 1;
    return true;
}

}  // namespace afm
