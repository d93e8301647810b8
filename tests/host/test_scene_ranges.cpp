// Unity tests of the scene's ranges (scene/scene_ranges.hpp kSceneRanges,
// one table for every number a scene gives). Each row is tried in a scene:
// at both of its ends (read, unless the end is open or the value must also
// lie inside a region, which its own check then refuses), just past each end,
// not whole where it must be, NaN and the infinities (refused, the message
// naming the file, the key and the value). A key the reader asks for without
// a row is a std::logic_error: the rows' scenes and every scene of scenes/
// reach each section the reader reads. docs/scenes.md's section "Ranges" is
// the table, row by row.
#include "scene.hpp"
#include "scene_ranges.hpp"

#include <yaml-cpp/yaml.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unity.h>   // after <cmath>: its isnan, isinf are math.h's

namespace {

std::string dir;

// A valid scene every row starts from: a 20 um field about frame A's origin,
// the path starting in a corner, clear of the objects the rows place.
const char *kBase = "name: ranges\nseed: 1\nduration_s: 2\nsample: {substrate: glass, field_nm: 20000}\n"
                    "operator: {path_nm: [[-9000, 9000]]}\n";

// Two particles whose ids are the ends of an id's range.
#define AFM_ID_ENDS "particles: [{id: 0, x_nm: -3000, y_nm: 0, radius_nm: 50}, {id: 1000000, x_nm: 3000, y_nm: 0, radius_nm: 50}]"

// What a row's key needs besides the base (the longest matching prefix
// wins): the section or list item it is read in, and what that needs.
const struct { const char *prefix, *yaml; } kSetups[] = {
    {"sample_rate_hz", "block_hz: 10000"},
    {"block_hz", "sample_rate_hz: 100000"},
    {"sample.slope_deg", "sample: {substrate: tilted_glass, slope_deg: 10}"},
    {"sample.wire.adhesion_nN_per_um", "sample: {wire: {adhesion_nN_per_um: 1}}"},
    {"sample.wire.shear_strength_MPa", "sample: {wire: {adhesion_nN_per_um: 1}}"},
    {"sample.field_center_nm", "sample: {field_center_nm: [0, 0]}"},
    {"sample.drift_nm_per_min", "sample: {drift_nm_per_min: [0, 0]}"},
    {"objects.particles[]", "objects: {particles: [{id: 1, x_nm: 0, y_nm: 0, radius_nm: 50}]}"},
    {"objects.wires[]", "objects: {wires: [{id: 1, x0_nm: -6000, y0_nm: 0, x1_nm: 6000, y1_nm: 0, diameter_nm: 100}]}"},
    {"objects.landmarks[]", "objects: {landmarks: [{id: 1, x_nm: 0, y_nm: 0}]}"},
    {"objects.scatter", "objects: {scatter: {count: 1, region_nm: [-5000, -5000, 5000, 5000]}}"},
    {"objects.scatter.count", "objects: {scatter: {count: 1, region_nm: [-9800, -9800, 9800, 7000]}}"},   // clear of the path's start
    {"objects.targets[]", "objects: {" AFM_ID_ENDS ", targets: [{x_nm: 0, y_nm: 0, particle: 0}]}\noperator: {plan: {}}"},
    {"objects.targets[][", "objects: {targets: [[0, 0]]}\noperator: {plan: {}}"},
    {"objects.targets.", "objects: {targets: {text: A, center_nm: [0, 0]}}\noperator: {plan: {}}"},
    {"objects.wire_targets[]",
     "objects: {wires: [{id: 0, x0_nm: -6000, y0_nm: -3000, x1_nm: 6000, y1_nm: -3000, diameter_nm: 100},"
     " {id: 1000000, x0_nm: -6000, y0_nm: 3000, x1_nm: 6000, y1_nm: 3000, diameter_nm: 100}],"
     " wire_targets: [{id: 0, x_nm: 0, y_nm: 0, angle_deg: 0}]}\noperator: {plan: {}}"},
    {"operator.plan.", "objects: {targets: [[0, 0]]}\noperator: {plan: {}}"},
    {"operator.plan.cuts[]",
     "effects: [lithography]\nsample: {substrate: polycarbonate}\n"
     "operator: {plan: {cuts: [{from_nm: [0, 0], to_nm: [1000, 0], load_nN: 50}]}}"},
    {"operator.local_scans[]", "objects: {" AFM_ID_ENDS "}\noperator: {local_scans: [{at_s: 0.5, around_id: 0}]}"},
    {"operator.cantilever_changes[]", "operator: {cantilever_changes: [{at_s: 0.5, offset_nm: [0, 0]}]}"},
    {"firmware.calibration.", "firmware: {calibration: {run: a test}}"},
};

// Copies `from` into `into`, mapping by mapping (from's values win).
void merge(YAML::Node into, const YAML::Node &from)
{
    for (auto it = from.begin(); it != from.end(); ++it) {
        const std::string k = it->first.Scalar();
        if (into[k].IsMap() && it->second.IsMap()) merge(into[k], it->second);
        else into[k] = YAML::Clone(it->second);
    }
}

// The base with what `key` needs.
YAML::Node setup_for(const std::string &key)
{
    YAML::Node root = YAML::Load(kBase);
    std::string best, yaml;
    for (const auto &s : kSetups)
        if (key.rfind(s.prefix, 0) == 0 && std::strlen(s.prefix) > best.size()) best = s.prefix, yaml = s.yaml;
    if (!yaml.empty()) merge(root, YAML::Load(yaml));
    return root;
}

// The key as an error names it in the setup's scene: each [] its first item.
std::string named(const std::string &key)
{
    std::string out;
    for (std::size_t i = 0; i < key.size(); ++i) out += key.compare(i, 2, "[]") == 0 ? (++i, "[0]") : std::string(1, key[i]);
    return out;
}

// Sets the value at `key` (a table key) to the scalar `text`: mappings are
// made on the way, list items and pair positions must be in the setup.
void set(YAML::Node root, const std::string &key, const std::string &text)
{
    YAML::Node n;
    n.reset(root);
    std::size_t i = 0;
    while (i < key.size()) {
        if (key[i] == '.') ++i;
        if (key[i] == '[') {
            const std::size_t close = key.find(']', i);
            const std::size_t at = close == i + 1 ? 0 : std::stoul(key.substr(i + 1, close - i - 1));
            TEST_ASSERT_TRUE_MESSAGE(n.IsSequence() && n.size() > at, ("the setup has no list at " + key).c_str());
            n.reset(n[at]);
            i = close + 1;
            continue;
        }
        const std::size_t end = key.find_first_of(".[", i);
        const std::string name = key.substr(i, end == std::string::npos ? std::string::npos : end - i);
        if (!n[name].IsDefined()) n[name] = YAML::Node(YAML::NodeType::Map);
        n.reset(n[name]);
        i = end == std::string::npos ? key.size() : end;
    }
    n = text;
}

int serial = 0;

// The scene's refusal ("" when it loads); its file in *path.
std::string refusal(const YAML::Node &root, std::string *path = nullptr)
{
    YAML::Emitter e;
    e << root;
    const std::string p = dir + "/scene" + std::to_string(serial++) + ".yaml";
    std::ofstream(p) << e.c_str() << "\n";
    if (path) *path = p;
    try {
        (void)afm::load_scene(p);
    } catch (const afm::SceneError &x) {
        return x.what();
    } catch (const std::logic_error &x) {   // a key without a row
        return std::string("(not a refusal) ") + x.what();
    }
    return "";
}

std::string text(double v, bool whole)
{
    char b[40];
    std::snprintf(b, sizeof b, whole ? "%.0f" : "%.17g", v);
    return b;
}

void expect_read(const afm::SceneRange &r, const std::string &value)
{
    YAML::Node root = setup_for(r.key);
    set(root, r.key, value);
    const std::string why = refusal(root);
    TEST_ASSERT_TRUE_MESSAGE(why.empty(), (std::string(r.key) + " = " + value + ": " + why).c_str());
}

// Refused, naming the file, the key (or, refused as a pair's, the pair) and the value.
void expect_refused(const afm::SceneRange &r, const std::string &value, bool as_pair = false)
{
    YAML::Node root = setup_for(r.key);
    set(root, r.key, value);
    std::string path;
    const std::string why = refusal(root, &path);
    const std::string what = std::string(r.key) + " = " + value + ": " + (why.empty() ? "read" : why);
    TEST_ASSERT_TRUE_MESSAGE(why.rfind(path + ": ", 0) == 0, what.c_str());
    std::string key = named(r.key);
    if (as_pair) key = key.substr(0, key.back() == ']' ? key.rfind('[') : key.rfind('.'));
    TEST_ASSERT_TRUE_MESSAGE(why.find(": " + key + ": ") != std::string::npos, what.c_str());
    const std::string says = as_pair ? std::string("outside ") + r.inside : "'" + value + "'";
    TEST_ASSERT_TRUE_MESSAGE(why.find(says) != std::string::npos, what.c_str());
}

// The row's end: read there, or refused (open, or outside its region), and
// refused just past it (a whole number's next whole number a double holds).
void try_end(const afm::SceneRange &r, double end, bool open, double outward)
{
    const bool whole = r.whole != nullptr;
    if (open) expect_refused(r, text(end, whole));
    else if (r.inside) expect_refused(r, text(end, whole), true);
    else expect_read(r, text(end, whole));
    const double past = std::nextafter(end, outward * HUGE_VAL);
    expect_refused(r, text(whole ? end + outward * std::max(1.0, std::fabs(past - end)) : past, whole));
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_every_row_holds_at_its_ends_and_refuses_past_them()
{
    for (const afm::SceneRange &r : afm::kSceneRanges) {
        std::string why;
        const YAML::Node base = setup_for(r.key);
        std::string path;
        why = refusal(base, &path);
        TEST_ASSERT_TRUE_MESSAGE(why.empty(), (std::string(r.key) + ": the row's setup is refused: " + why).c_str());
        const afm::Scene s = afm::load_scene(path);
        const double lo = afm::scene_bound(r.lo, &s), hi = afm::scene_bound(r.hi, &s);
        TEST_ASSERT_TRUE_MESSAGE(lo < hi, r.key);
        try_end(r, lo, r.lo_open, -1);
        try_end(r, hi, r.hi_open, +1);
        if (r.whole && lo + 0.5 < hi) expect_refused(r, text(lo + 0.5, false));
        for (const char *bad : {".nan", ".inf", "-.inf", "nan", "inf", "1e999", "12abc"}) expect_refused(r, bad);
    }
}

void test_a_key_without_a_row_is_a_programming_error()
{
    bool thrown = false;
    try {
        (void)afm::scene_range("sample.no_such_key_nm");
    } catch (const std::logic_error &e) {
        thrown = std::strstr(e.what(), "sample.no_such_key_nm") != nullptr;
    }
    TEST_ASSERT_TRUE(thrown);
    TEST_ASSERT_EQUAL_STRING("objects.particles[].x_nm", afm::scene_range("objects.particles[12].x_nm").key);
    TEST_ASSERT_EQUAL_STRING("operator.path_nm[][1]", afm::scene_range("operator.path_nm[3][1]").key);
    TEST_ASSERT_EQUAL_STRING("objects.scatter.region_nm[2]", afm::scene_range("objects.scatter.region_nm[2]").key);
}

void test_the_rows_are_unique_and_written_as_a_user_writes_them()
{
    std::set<std::string> keys;
    for (const afm::SceneRange &r : afm::kSceneRanges) {
        TEST_ASSERT_TRUE_MESSAGE(keys.insert(r.key).second, r.key);
        TEST_ASSERT_EQUAL_STRING(r.key, afm::scene_range_key(r.key).c_str());
        TEST_ASSERT_TRUE_MESSAGE(r.unit != nullptr, r.key);
    }
}

// Every scene of scenes/ reads (the reader asks for no key without a row).
void test_every_committed_scene_reads()
{
    int n = 0;
    for (const auto &f : std::filesystem::recursive_directory_iterator(AFM_SOURCE_DIR "/scenes")) {
        if (f.path().extension() != ".yaml") continue;
        try {
            (void)afm::load_scene(f.path().string());
        } catch (const std::exception &e) {
            TEST_FAIL_MESSAGE((f.path().string() + ": " + e.what()).c_str());
        }
        ++n;
    }
    TEST_ASSERT_GREATER_THAN(20, n);
}

// docs/scenes.md's section "Ranges" is the table: its rows are
// scene_range_doc_row's, in order; a difference prints the section's rows.
void test_the_docs_show_the_table()
{
    std::ifstream in(AFM_SOURCE_DIR "/docs/scenes.md");
    std::vector<std::string> doc;
    bool inside = false;
    for (std::string line; std::getline(in, line);) {
        if (line.rfind("## ", 0) == 0) inside = line == "## Ranges";
        else if (inside && line.rfind("| `", 0) == 0) doc.push_back(line);
    }
    std::string want, got;
    for (const afm::SceneRange &r : afm::kSceneRanges) want += afm::scene_range_doc_row(r) + "\n";
    for (const auto &l : doc) got += l + "\n";
    if (want != got) std::printf("docs/scenes.md, section \"## Ranges\", should list:\n%s", want.c_str());
    TEST_ASSERT_EQUAL_STRING(want.c_str(), got.c_str());
}

int main()
{
    char tmpl[] = "/tmp/afm-test-scene-ranges-XXXXXX";
    if (!mkdtemp(tmpl)) return 1;
    dir = tmpl;
    UNITY_BEGIN();
    RUN_TEST(test_every_row_holds_at_its_ends_and_refuses_past_them);
    RUN_TEST(test_a_key_without_a_row_is_a_programming_error);
    RUN_TEST(test_the_rows_are_unique_and_written_as_a_user_writes_them);
    RUN_TEST(test_every_committed_scene_reads);
    RUN_TEST(test_the_docs_show_the_table);
    const int failures = UNITY_END();
    std::filesystem::remove_all(dir);
    return failures;
}
