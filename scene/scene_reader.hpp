// The scene reader's parts, internal to common/ (scene.hpp is the
// interface): the Reader that walks a scene's YAML and names file and key in
// every refusal, and the readers and checks of the scene's sections, one
// file a role:
//   scene_reader.cpp    the Reader's includes bookkeeping and a material pair
//   scene_sample.cpp    effects, sample, probe, firmware, afm
//   scene_objects.cpp   objects (particles, scatter, wires, landmarks,
//                       targets) and the checks of where they and the path start
//   scene_operator.cpp  operator (haptic, plan, path, scans), outputs, expect
//   scene_include.cpp   the scene file, its includes merged, their refusals
//   scene.cpp           load_scene (the order the sections are read in) and
//                       the Scene's derived quantities
// Every number is checked against its row of kSceneRanges (scene_ranges.hpp).
#pragma once

#include <yaml-cpp/yaml.h>

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "scene.hpp"
#include "scene_ranges.hpp"
#include "text.hpp"

namespace afm::scene_detail {


// The nodes the includes brought into the scene this thread reads
// (merge_missing adds them; resolved_yaml starts the list afresh): an error
// never quotes them, as an included file is never quoted.
extern thread_local std::vector<YAML::Node> t_included;

// Whether n is tree or inside it (by identity, keys too).
bool within(const YAML::Node &tree, const YAML::Node &n);
// Whether n came from an included file (t_included): never quoted.
bool from_include(const YAML::Node &n);

// Walks a YAML tree, remembering the key path, so every error names file and key.
class Reader {
public:
    // scene: where bounds of the scene's own (the field, duration_s) are
    // read from, as far as it is read (scene_ranges.hpp)
    explicit Reader(std::string file, const Scene *scene = nullptr) : file_(std::move(file)), scene_(scene) {}

    // `what` is the message's own text with values quoted by show(); the
    // file and the key (a scene's key may be any bytes) are escaped here.
    [[noreturn]] void fail(const std::string &key, const std::string &what) const
    {
        throw SceneError(afm::printable(file_) + ": " + afm::printable(key) + ": " + what);
    }

    // Text a run can write into run.json and a terminal as it is: valid
    // UTF-8 without C0 or C1 control characters (text.hpp's escaper leaves
    // it unchanged but for its backslashes, which are allowed).
    static bool printable_utf8(std::string t)
    {
        t.erase(std::remove(t.begin(), t.end(), '\\'), t.end());
        return afm::printable(t) == t;
    }

    // A value as an error message quotes it: escaped (text.hpp: a scene
    // must not write to the terminal), and at most kShowMax bytes of it (a
    // file included by mistake is not quoted).
    static constexpr std::size_t kShowMax = 80;
    static std::string show(const YAML::Node &n)
    {
        if (!n.IsDefined() || n.IsNull()) return "null";
        if (from_include(n)) return "(a value of an included file: not quoted)";
        if (n.IsScalar()) return "'" + shortened(n.Scalar()) + "'";
        YAML::Emitter e;
        e << YAML::Flow << n;
        return shortened(e.c_str());
    }
    static std::string shortened(const std::string &t)
    {
        if (t.size() <= kShowMax) return afm::printable(t);
        return afm::printable(t.substr(0, kShowMax)) + "... (" + std::to_string(t.size()) + " characters)";
    }

    // The one refusal of a section that is not a mapping of known keys:
    // not a mapping ("must be a mapping {a, b}, got ..."), a key that is not
    // a name, a key given twice, a key not in `allowed`. Call it before any
    // map[key] lookup: yaml-cpp throws its own error indexing a scalar.
    void only_keys(const YAML::Node &map, const std::string &path, std::set<std::string> allowed) const
    {
        std::string list;
        for (const auto &a : allowed) list += (list.empty() ? "" : ", ") + a;
        if (!map.IsMap()) fail(path.empty() ? "(top level)" : path, "must be a mapping {" + list + "}, got " + show(map));
        std::set<std::string> seen;
        for (auto it = map.begin(); it != map.end(); ++it) {
            if (!it->first.IsScalar()) fail(path.empty() ? "(top level)" : path, "a key must be a name, got " + show(it->first));
            const std::string k = it->first.Scalar();
            // yaml-cpp keeps both copies of a key given twice; the reader would see only the first
            if (!seen.insert(k).second) fail(join(path, k), "given twice");
            if (!allowed.count(k) && from_include(it->first))
                fail(path.empty() ? "(top level)" : path, "an included file has a key not known here (not quoted: an included file)");
            if (!allowed.count(k)) fail(join(path, k), "unknown key (known here: " + list + ")");
        }
    }

    static std::string join(const std::string &path, const std::string &k)
    {
        return path.empty() ? k : path + "." + k;
    }

    // The number at map[k], in its kSceneRanges row's range (*dflt when
    // missing; a missing value without a default is refused).
    double num(const YAML::Node &map, const std::string &path, const std::string &k, const double *dflt) const
    {
        const std::string key = join(path, k);
        const SceneRange &range = scene_range(key);   // a key without a row fails here, given or not
        YAML::Node n = map[k];
        if (!n.IsDefined() || n.IsNull()) {
            if (!dflt) fail(key, "required value is missing");
            return *dflt;
        }
        return check_num(n, key, range);
    }

    double check_num(const YAML::Node &n, const std::string &key) const { return check_num(n, key, scene_range(key)); }

    // n as a number in range r: finite, within both ends, whole if r says so.
    double check_num(const YAML::Node &n, const std::string &key, const SceneRange &r) const
    {
        if (!n.IsScalar()) fail(key, "must be a number, got " + show(n));
        double v;
        try {
            v = n.as<double>();
        } catch (const YAML::Exception &) {
            fail(key, "must be a number, got " + show(n));
        }
        if (!std::isfinite(v)) fail(key, "must be a finite number, got " + show(n));
        const double lo = scene_bound(r.lo, scene_), hi = scene_bound(r.hi, scene_);
        const bool low = r.lo_open ? !(v > lo) : !(v >= lo), high = r.hi_open ? !(v < hi) : !(v <= hi);
        if (low || high) {
            std::ostringstream o;
            if (low) o << "must be " << (r.lo_open ? "> " : ">= ") << lo << ", got " << show(n);
            else o << "must be " << (r.hi_open ? "< " : "<= ") << hi << ", got " << show(n);
            fail(key, o.str());
        }
        if (r.whole && v != std::floor(v)) fail(key, std::string("must be ") + r.whole + ", got " + show(n));
        return v;
    }

    std::string str(const YAML::Node &map, const std::string &path, const std::string &k,
                    const std::string *dflt, std::set<std::string> choices = {}) const
    {
        const std::string key = join(path, k);
        YAML::Node n = map[k];
        if (!n.IsDefined() || n.IsNull()) {
            if (!dflt) fail(key, "required value is missing");
            return *dflt;
        }
        if (!n.IsScalar()) fail(key, "must be a string, got " + show(n));
        std::string v = n.Scalar();
        if (!printable_utf8(v)) fail(key, "must be printable UTF-8 text (it is written into run.json)");
        if (!choices.empty() && !choices.count(v)) {
            std::string list;
            for (const auto &c : choices) list += (list.empty() ? "" : ", ") + c;
            fail(key, "must be one of " + list + ", got " + show(n));
        }
        return v;
    }

    Vec2 vec2(const YAML::Node &n, const std::string &key) const
    {
        if (!n.IsSequence() || n.size() != 2) fail(key, "must be a pair [x, y], got " + show(n));
        return Vec2{check_num(n[0], key + "[0]"), check_num(n[1], key + "[1]")};
    }

    bool boolean(const YAML::Node &map, const std::string &path, const std::string &k, bool dflt) const
    {
        YAML::Node n = map[k];
        if (!n.IsDefined() || n.IsNull()) return dflt;
        try {
            return n.as<bool>();
        } catch (const YAML::Exception &) {
            fail(join(path, k), "must be true or false, got " + show(n));
        }
    }

private:
    std::string file_;
    const Scene *scene_;
};

// scene_reader.cpp
ContactSpec read_contact(const Reader &r, const YAML::Node &n, const std::string &path, ContactSpec d, bool with_area);

// scene_sample.cpp
void read_effects(const Reader &r, const YAML::Node &root, Scene &s);
void read_substrate(const Reader &r, const YAML::Node &smp, Scene &s);
void check_map_covers_field(const Reader &r, const Scene &s);
void read_sample(const Reader &r, const YAML::Node &root, Scene &s);
void read_probe(const Reader &r, const YAML::Node &root, Scene &s);
void read_firmware(const Reader &r, const YAML::Node &root, Scene &s);
void read_afm(const Reader &r, const YAML::Node &root, Scene &s);

// scene_objects.cpp
void read_scatter(const Reader &r, const YAML::Node &n, Scene &s);
int read_pin(const Reader &r, const YAML::Node &n, const std::string &key, const Scene &s);
void read_targets(const Reader &r, const YAML::Node &n, Scene &s);
void read_wire_targets(const Reader &r, const YAML::Node &n, Scene &s);
void read_particles(const Reader &r, const YAML::Node &ps, Scene &s);
void read_objects(const Reader &r, const YAML::Node &root, Scene &s);
double segment_gap(Vec2 a, Vec2 b, Vec2 c, Vec2 d);
std::string particle_key(const Scene &s, std::size_t i);
void check_overlaps(const Reader &r, const Scene &s);
void check_path_start(const Reader &r, const Scene &s);

// scene_operator.cpp
void read_haptic(const Reader &r, const YAML::Node &op, Scene &s);
void read_plan_cuts(const Reader &r, const YAML::Node &n, Scene &s);
void read_plan(const Reader &r, const YAML::Node &op, Scene &s);
void check_plan(const Reader &r, const Scene &s);
void read_operator(const Reader &r, const YAML::Node &root, Scene &s);
void read_outputs(const Reader &r, const YAML::Node &root, Scene &s);
void read_expect(const Reader &r, const YAML::Node &root, Scene &s);

// scene_include.cpp
// The keys a scene may have at its top level.
extern const std::set<std::string> kTopLevelKeys;
void check_scene_file(const std::string &path, const std::string &what);
YAML::Node load_yaml(const std::string &path, const std::string &what);
std::string dir_of(const std::string &path);
void merge_missing(YAML::Node into, const YAML::Node &from);
void check_include_keys(const std::string &fp, const YAML::Node &part);
YAML::Node resolved_yaml(const std::string &path);

}  // namespace afm::scene_detail
