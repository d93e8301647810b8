#include "scene_ranges.hpp"

#include "scene.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace afm {

std::string scene_range_key(const std::string &key)
{
    std::string out;
    for (std::size_t i = 0; i < key.size();) {
        std::size_t j = i + 1;
        if (key[i] == '[')
            while (j < key.size() && std::isdigit(static_cast<unsigned char>(key[j]))) ++j;
        const bool index = key[i] == '[' && j > i + 1 && j < key.size() && key[j] == ']';
        if (index && j + 1 < key.size()) {   // a list's item: more of the path follows
            out += "[]";
            i = j + 1;
        } else {
            out += key[i];
            ++i;
        }
    }
    return out;
}

const SceneRange &scene_range(const std::string &key)
{
    const std::string k = scene_range_key(key);
    for (const SceneRange &r : kSceneRanges)
        if (k == r.key) return r;
    throw std::logic_error("scene_ranges.hpp: no row of kSceneRanges for the scene key " + k + " (read as " + key + ")");
}

double scene_bound(const SceneBound &b, const Scene *s)
{
    if (b.ref == SceneRef::kNumber) return b.number;
    if (!s) throw std::logic_error("scene_bound: a bound of the scene's (" + scene_bound_text(b) + ") without a scene");
    const double h = s->field_nm / 2, cx = s->field_center_nm.x, cy = s->field_center_nm.y;
    switch (b.ref) {
    case SceneRef::kField: return s->field_nm;
    case SceneRef::kFieldHalfNeg: return -h;
    case SceneRef::kFieldHalf: return h;
    case SceneRef::kFieldXLo: return cx - h;
    case SceneRef::kFieldXHi: return cx + h;
    case SceneRef::kFieldYLo: return cy - h;
    case SceneRef::kFieldYHi: return cy + h;
    case SceneRef::kDuration: return s->duration_s;
    case SceneRef::kNumber: break;
    }
    return b.number;
}

std::string scene_bound_text(const SceneBound &b)
{
    switch (b.ref) {
    case SceneRef::kNumber: break;
    case SceneRef::kField: return "f";
    case SceneRef::kFieldHalfNeg: return "-f/2";
    case SceneRef::kFieldHalf: return "f/2";
    case SceneRef::kFieldXLo: return "cx - f/2";
    case SceneRef::kFieldXHi: return "cx + f/2";
    case SceneRef::kFieldYLo: return "cy - f/2";
    case SceneRef::kFieldYHi: return "cy + f/2";
    case SceneRef::kDuration: return "duration_s";
    }
    char t[40];
    if (b.number == std::floor(b.number) && std::fabs(b.number) <= 1e5) {   // 45, 4096, 90000; 1e+06 past that
        std::snprintf(t, sizeof t, "%.0f", b.number);
        return t;
    }
    for (int digits = 1; digits <= 17; ++digits) {   // the shortest text that reads back as the bound
        std::snprintf(t, sizeof t, "%.*g", digits, b.number);
        if (std::strtod(t, nullptr) == b.number) break;
    }
    return t;
}

std::string scene_range_doc_row(const SceneRange &r)
{
    std::string range = std::string(r.lo_open ? "(" : "[") + scene_bound_text(r.lo) + ", " + scene_bound_text(r.hi) + (r.hi_open ? ")" : "]");
    if (r.whole) range += ", " + std::string(r.whole);
    if (r.inside) range += ", and inside " + std::string(r.inside);
    return "| `" + std::string(r.key) + "` | " + range + " | " + r.unit + " |";
}

}  // namespace afm
