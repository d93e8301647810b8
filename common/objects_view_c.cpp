#include "objects_view_c.h"

#include <climits>
#include <stdexcept>
#include <vector>

#include "objects_view.hpp"

namespace {

// The whole set, encoded with its fingerprint, as a log holds it.
bool encode(const afm::objects_t &m, std::vector<uint8_t> &out)
{
    const int n = m.getEncodedSize();
    if (n < 0) return false;
    out.resize(static_cast<std::size_t>(n));
    return m.encode(out.data(), 0, n) == n;
}

}  // namespace

extern "C" {

// No C++ exception leaves these functions (a caller in C or Python cannot
// catch one): each is caught and said as the documented failure.

void *afm_objects_view_new(void)
{
    try {
        return new afm::ObjectsView();
    } catch (...) {
        return nullptr;
    }
}

void afm_objects_view_free(void *view) { delete static_cast<afm::ObjectsView *>(view); }

int afm_objects_view_apply(void *view, const uint8_t *data, size_t len, afm_objects_placed_fn placed, void *ctx)
{
    auto *v = static_cast<afm::ObjectsView *>(view);
    if (!v || (!data && len) || len > static_cast<size_t>(INT_MAX)) return -1;
    try {
        afm::objects_t m;
        if (m.decode(data, 0, static_cast<int>(len)) < 0) return -1;
        std::vector<uint8_t> buf;
        const auto tell = [&](const afm::objects_t &p) {
            // a set placed but not told to the caller would be lost to it: fail instead
            if (!encode(v->whole(), buf)) throw std::runtime_error("cannot encode the set");
            placed(ctx, p.seq, p.fix_id, buf.data(), buf.size());
        };
        switch (v->apply(m, placed ? afm::ObjectsView::Placed(tell) : nullptr)) {
        case afm::ObjectsView::Take::applied: return 0;
        case afm::ObjectsView::Take::held: return 1;
        case afm::ObjectsView::Take::refused: return 2;
        }
        return 2;
    } catch (...) {
        return -1;
    }
}

}  // extern "C"
