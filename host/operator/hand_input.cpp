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

int HandInput::open_from_env(const char *unset_why, const char *what)
{
    const char *path = std::getenv("AFM_HAND_FIFO");
    if (!path || !*path) throw InputError(std::string("operator: ") + unset_why + " (AFM_HAND_FIFO is not set)");
    const int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        throw InputError(std::string("operator: cannot open ") + what + ", AFM_HAND_FIFO " + path + ": " + std::strerror(errno));
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
            if (nl > kMaxLine) refuse("line too long");
            else if (const std::string why = take_line(partial_.substr(0, nl)); !why.empty()) refuse(why);
            partial_.erase(0, nl + 1);
        }
        if (partial_.size() > kMaxLine) {   // a line too long: dropped up to its end
            partial_.clear();
            refuse("line too long");
        }
    }
}

void HandInput::refuse(const std::string &why)
{
    ++refused_;
    ++refusals_[why];
}

std::string HandInput::take_line(const std::string &line)
{
    std::istringstream in(line);
    std::string word;
    in >> word;
    if (word == "HAND") {
        Command c;
        if (std::string why = parse(line, &c); !why.empty()) return why;
        if (yielded_) {   // a stroke drives the tip: the hand waits
            ++held_;
            return "";
        }
        cmd_ = c;
        ++taken_;
        return "";
    }
    if (word == "SCAN") {
        ScanAsk a;
        if (std::string why = parse_scan(line, &a); !why.empty()) return why;
        scan_ = a;
        scan_pending_ = true;
        ++scans_asked_;
        return "";
    }
    if (word == "PUSH") {
        PushAsk a;
        if (std::string why = parse_push(line, &a); !why.empty()) return why;
        push_ = a;
        push_pending_ = true;
        ++pushes_asked_;
        return "";
    }
    return "not a command";
}

bool HandInput::take_scan(ScanAsk *s)
{
    if (!scan_pending_) return false;
    *s = scan_;
    scan_pending_ = false;
    return true;
}

bool HandInput::take_push(PushAsk *p)
{
    if (!push_pending_) return false;
    *p = push_;
    push_pending_ = false;
    return true;
}

void HandInput::hand_back(Vec2 aim_nm)
{
    cmd_.aim_nm = aim_nm;
    cmd_.engaged = false;
    yielded_ = false;
}

bool HandInput::in_field(Vec2 p_nm, double margin_nm) const
{
    const double half = scene_.field_nm / 2 - margin_nm;
    return std::isfinite(p_nm.x) && std::isfinite(p_nm.y) && std::fabs(p_nm.x - scene_.field_center_nm.x) <= half &&
           std::fabs(p_nm.y - scene_.field_center_nm.y) <= half;
}

std::string HandInput::parse_scan(const std::string &line, ScanAsk *s) const
{
    std::istringstream in(line);
    std::string word, rest;
    if (!(in >> word >> s->center_nm.x >> s->center_nm.y >> s->size_nm) || word != "SCAN" || (in >> rest)) return "not a command";
    if (!in_field(s->center_nm)) return "outside the field";
    const double min_nm = kMinScanPx * scene_.field_nm / scene_.out.image_px;
    if (!(std::isfinite(s->size_nm) && s->size_nm >= min_nm && s->size_nm <= scene_.field_nm)) return "scan size out of range";
    return "";
}

std::string HandInput::parse_push(const std::string &line, PushAsk *p) const
{
    std::istringstream in(line);
    std::string word, id, rest;
    if (!(in >> word >> id >> p->target_nm.x >> p->target_nm.y) || word != "PUSH" || (in >> rest)) return "not a command";
    // the id: digits only (no sign, point or exponent), at most 9 of them
    if (id.empty() || id.size() > 9 || id.find_first_not_of("0123456789") != std::string::npos) return "not a command";
    p->id = std::stoi(id);
    const ParticleSpec *found = nullptr;
    for (const auto &q : scene_.particles)
        if (q.id == p->id) found = &q;
    if (!found) return "unknown particle";
    if (!in_field(p->target_nm, found->radius_nm)) return "target outside the field";
    return "";
}

std::string HandInput::parse(const std::string &line, Command *c) const
{
    std::istringstream in(line);
    std::string word, rest;
    int engaged = -1;
    if (!(in >> word >> c->aim_nm.x >> c->aim_nm.y >> c->load_nN >> engaged) || word != "HAND" || (in >> rest)) return "not a command";
    if (engaged != 0 && engaged != 1) return "not a command";
    if (!in_field(c->aim_nm)) return "outside the field";
    if (!(std::isfinite(c->load_nN) && c->load_nN > 0 && c->load_nN <= kMaxLoad_nN)) return "load out of range";
    c->engaged = engaged == 1;
    return "";
}

}  // namespace afm
