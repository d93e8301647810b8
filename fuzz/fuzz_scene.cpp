// Fuzz target "scene": the scene parser and validator (afm::load_scene,
// scene/scene.cpp) on any bytes as a scene file, and the card's check of
// the scene that follows it in ./afm check and before every run.
//
// A SceneError is the validator's clean refusal. Anything else escaping
// (another exception, a sanitizer's report, a hang) is a crash. A scene the
// validator takes must also survive the copy a run keeps of it
// (resolved_scene_text: includes merged in, re-emitted by yaml-cpp): that
// copy, loaded again, is the same scene (./afm replay reads it). Its text
// must fit run.json (nlohmann::json, UTF-8). The card then accepts it or
// names the rule (afm::card_refusal, afm::haptic_refusal, as the launcher
// checks); a scene it accepts it must initialise with (afm::CardNode) and
// step a block of.
//
// A scene may include other files (include: FILE); the input lives alone in
// a private folder beside one calibration file it may include
// (calibration.yaml). An include that leaves the folder (an absolute path,
// or one through "..") is not run: /dev/zero or a large file would only
// measure the disk.
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "card_node.hpp"
#include "card_setup.hpp"
#include "fuzz_files.hpp"
#include "haptic_bound.hpp"
#include "scene.hpp"

namespace {

const char kCalibration[] =
    "# What ./afm calib ... --write writes: the card's calibrated constants.\n"
    "firmware:\n"
    "  lateral_nN_per_V: 37.900   # k_theta K_l / h\n"
    "  mu: 0.086500               # tip-substrate\n"
    "  disp_n_nm_per_V: 23.140    # C_n\n";

const afm_fuzz::Folder &folder()
{
    static const afm_fuzz::Folder f("scene");
    static const bool written = (f.write("calibration.yaml", kCalibration), true);
    (void)written;
    return f;
}

// (An empty name opens nothing: scene.cpp refuses it.)
bool stays_inside(const std::string &name) { return name.empty() || (name[0] != '/' && name.find("..") == std::string::npos); }

// Whether every file the scene names in include: stays in the folder
// (include: a name or a list of names). Every include key counts: yaml-cpp
// keeps a key given twice, scene.cpp follows the first, and the copy of the
// scene keeps the others. Input yaml-cpp cannot parse has no include to follow.
bool includes_stay_inside(const std::string &text)
{
    YAML::Node root;
    try {
        root = YAML::Load(text);
    } catch (const YAML::Exception &) {
        return true;
    }
    if (!root.IsMap()) return true;
    for (auto it = root.begin(); it != root.end(); ++it) {
        if (!it->first.IsScalar() || it->first.Scalar() != "include") continue;
        const YAML::Node inc = it->second;
        if (inc.IsScalar() && !stays_inside(inc.Scalar())) return false;
        if (inc.IsSequence())
            for (const auto &f : inc)
                if (f.IsScalar() && !stays_inside(f.Scalar())) return false;
    }
    return true;
}

void same(bool ok, const char *what)
{
    if (!ok) afm_fuzz::broken(what);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, std::size_t size)
{
    const afm_fuzz::Folder &dir = folder();
    const std::string text(reinterpret_cast<const char *>(data), size);
    if (!includes_stay_inside(text)) return -1;   // not kept in the corpus
    const std::string path = dir.write("scene.yaml", data, size);
    afm::Scene s;
    try {
        s = afm::load_scene(path);
    } catch (const afm::SceneError &) {
        return 0;
    } catch (const std::exception &e) {
        afm_fuzz::broken("load_scene lets an exception other than SceneError escape", e.what());
    }
    // What run.json says of the scene (the launcher writes it with nlohmann::json).
    try {
        const nlohmann::json j = {{"scene_name", s.name}, {"effects", s.effects}, {"text", s.targets.text}, {"png", s.targets.png}};
        (void)j.dump();
    } catch (const nlohmann::json::exception &e) {
        afm_fuzz::broken("the validator takes text run.json cannot hold", e.what());
    }

    // The run's copy of the scene is the same scene.
    const std::string copy = dir.write("copy.yaml", afm::resolved_scene_text(path));
    afm::Scene c;
    try {
        c = afm::load_scene(copy);
    } catch (const afm::SceneError &e) {
        afm_fuzz::broken("resolved_scene_text gives a scene load_scene refuses", e.what());
    }
    same(c.name == s.name && c.seed == s.seed, "the copy's name or seed differs");
    same(c.duration_s == s.duration_s && c.sample_rate_hz == s.sample_rate_hz && c.block_hz == s.block_hz &&
             c.frame_rate_hz == s.frame_rate_hz,
         "the copy's rates differ");
    same(c.effects == s.effects, "the copy's effects differ");
    same(c.particles.size() == s.particles.size() && c.wires.size() == s.wires.size() &&
             c.landmarks.size() == s.landmarks.size(),
         "the copy's objects differ");
    same(c.op.path_nm.size() == s.op.path_nm.size(), "the copy's operator path differs");
    same(c.total_blocks() == s.total_blocks() && c.total_frames() == s.total_frames(), "the copy's length differs");

    // The card's check (as the launcher's), and a block on a card that passed it.
    if (!afm::card_refusal(s).empty()) return 0;
    {
        const afm::CardSetup card(s);
        if (!afm::haptic_refusal(s, card.config()).empty()) return 0;
    }
    try {
        afm::CardNode node(s);
        afm::haptic_pose_t p{};
        p.engaged = s.start_engaged();
        afm::analog_block_t b{};
        b.fs_hz = s.sample_rate_hz;
        b.n = s.samples_per_block();
        for (auto *v : {&b.sn_v, &b.sl_v, &b.piezo_x_nm, &b.piezo_y_nm, &b.piezo_z_nm})
            v->assign(static_cast<std::size_t>(b.n), 0.0);
        b.piezo_x_nm.assign(static_cast<std::size_t>(b.n), s.start_nm().x);
        b.piezo_y_nm.assign(static_cast<std::size_t>(b.n), s.start_nm().y);
        node.on_pose(p);
        node.on_analog(b);
        same(node.done() == 0, "the card did not step block 0");
    } catch (const std::exception &e) {
        afm_fuzz::broken("card_refusal accepts a scene the card refuses", e.what());
    }
    return 0;
}
