// The scene file and its includes (scene_reader.hpp): read, capped, merged,
// their refusals never quoting an included file; the resolved text a run keeps.
#include "scene_reader.hpp"

namespace afm::scene_detail {



// A scene file, or a file it includes, is at most this large (a scene of
// thousands of listed objects is well under it).
constexpr long long kMaxSceneBytes = 4 << 20;

// Refuses, by its type and before any read, what is not a regular file (a
// directory aborted the reader; a FIFO hung it), and a file over the cap.
void check_scene_file(const std::string &path, const std::string &what)
{
    struct stat st {};
    if (stat(path.c_str(), &st) != 0) throw SceneError(afm::printable(path) + ": cannot open " + what + " (no such file or not readable)");
    if (!S_ISREG(st.st_mode)) {
        const char *kind = S_ISDIR(st.st_mode) ? "a directory" : S_ISFIFO(st.st_mode) ? "a FIFO"
                           : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "a device" : S_ISSOCK(st.st_mode) ? "a socket" : "not a regular file";
        throw SceneError(afm::printable(path) + ": cannot read " + what + ": it is " + kind + ", not a file");
    }
    if (st.st_size > kMaxSceneBytes)
        throw SceneError(afm::printable(path) + ": " + what + " of " + std::to_string(static_cast<long long>(st.st_size)) +
                         " bytes is larger than a scene may be (" + std::to_string(kMaxSceneBytes) + " bytes)");
}

YAML::Node load_yaml(const std::string &path, const std::string &what)
{
    check_scene_file(path, what);
    {
        std::ifstream probe(path);
        if (!probe) throw SceneError(afm::printable(path) + ": cannot open " + what + " (no such file or not readable)");
    }
    YAML::Node n;
    try {
        n = YAML::LoadFile(path);
    } catch (const YAML::ParserException &e) {
        throw SceneError(afm::printable(path) + ": YAML syntax error at line " + std::to_string(e.mark.line + 1) + ": " + afm::printable(e.msg));
    }
    if (!n.IsDefined() || n.IsNull()) throw SceneError(afm::printable(path) + ": the " + what + " is empty");
    return n;
}

std::string dir_of(const std::string &path)
{
    const auto slash = path.find_last_of('/');
    return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

// Copies what `from` has and `into` lacks, recursively through mappings
// (the including file's own values win).
void merge_missing(YAML::Node into, const YAML::Node &from)
{
    for (auto it = from.begin(); it != from.end(); ++it) {
        const std::string k = it->first.as<std::string>();
        if (!into[k].IsDefined() || into[k].IsNull()) {
            into[k] = YAML::Clone(it->second);
            t_included.push_back(into[k]);
        }
        else if (into[k].IsMap() && it->second.IsMap()) merge_missing(into[k], it->second);
    }
}

// The scene's YAML with its includes merged in (include: FILE or [FILE,
// ...], relative to the scene; each may hold probe, firmware and sample
// only: a lever's calibration, ./afm calib ... --write), and a PNG
// target's path made absolute, so the tree stands alone.
// The keys a scene may have at its top level.
const std::set<std::string> kTopLevelKeys = {"name", "seed", "duration_s", "sample_rate_hz", "block_hz", "frame_rate_hz",
                                             "time_mode", "effects", "sample", "probe", "firmware", "objects", "operator",
                                             "outputs", "include", "afm", "expect"};

// An included file holds probe, firmware and sample only. Its refusals
// name the file and the line but never quote it: an include may name a
// file the scene's author could not read (include: /etc/shadow printed
// root's hash as the value that was not a mapping).
void check_include_keys(const std::string &fp, const YAML::Node &part)
{
    const std::string file = afm::printable(fp);
    if (!part.IsMap())
        throw SceneError(file + ": an included file must be a mapping of probe, firmware and sample (not quoted here: it is "
                                "an included file)");
    std::set<std::string> seen;
    for (auto it = part.begin(); it != part.end(); ++it) {
        const std::string line = std::to_string(it->first.Mark().line + 1);
        const bool known = it->first.IsScalar() && (it->first.Scalar() == "probe" || it->first.Scalar() == "firmware" ||
                                                    it->first.Scalar() == "sample");
        if (!known)
            throw SceneError(file + ": line " + line + ": a key other than probe, firmware or sample (not quoted here: it is "
                                    "an included file)");
        if (!seen.insert(it->first.Scalar()).second) throw SceneError(file + ": line " + line + ": " + it->first.Scalar() + " given twice");
    }
}

YAML::Node resolved_yaml(const std::string &path)
{
    t_included.clear();
    YAML::Node root = load_yaml(path, "scene file");
    const Reader r(path);
    // before the includes are merged (and the include key removed): a key
    // given twice, or one that is not a name, is refused as the scene has it
    r.only_keys(root, "", kTopLevelKeys);
    YAML::Node inc = root["include"];
    if (inc.IsDefined() && !inc.IsNull()) {
        std::vector<std::string> files;
        if (inc.IsScalar()) files.push_back(inc.Scalar());
        else if (inc.IsSequence())
            for (const auto &f : inc) {
                if (!f.IsScalar()) r.fail("include", "must be a file name or a list of them, got " + Reader::show(inc));
                files.push_back(f.Scalar());
            }
        else r.fail("include", "must be a file name or a list of them, got " + Reader::show(inc));
        for (const std::string &f : files) {
            const std::string fp = f.empty() || f[0] == '/' ? f : dir_of(path) + "/" + f;
            const YAML::Node part = load_yaml(fp, "included file (include: of " + afm::printable(path) + ")");
            check_include_keys(fp, part);
            try {
                merge_missing(root, part);
            } catch (const YAML::Exception &e) {   // a nested key that is not a name
                Reader(fp).fail("(included)", std::string("cannot merge: ") + e.what());
            }
        }
        root.remove("include");
    }
    // sample.substrate.gsf, like the includes, relative to the scene
    const YAML::Node sample = root["sample"];
    if (sample.IsDefined() && sample.IsMap() && sample["substrate"].IsDefined() && sample["substrate"].IsMap()) {
        YAML::Node sub = root["sample"]["substrate"];
        const YAML::Node gsf = sub["gsf"];
        if (gsf.IsDefined() && gsf.IsScalar() && !gsf.Scalar().empty() && gsf.Scalar()[0] != '/')
            sub["gsf"] = dir_of(path) + "/" + gsf.Scalar();
    }
    // (Indexing a node by a key turns a sequence into a mapping: look first.)
    const YAML::Node objects = root["objects"];
    if (objects.IsDefined() && objects.IsMap() && objects["targets"].IsDefined() && objects["targets"].IsMap()) {
        YAML::Node targets = root["objects"]["targets"];
        const YAML::Node png = targets["png"];
        if (png.IsDefined() && png.IsScalar() && !png.Scalar().empty() && png.Scalar()[0] != '/')
            targets["png"] = dir_of(path) + "/" + png.Scalar();
    }
    return root;
}

}  // namespace afm::scene_detail

namespace afm {

using scene_detail::resolved_yaml;

std::string resolved_scene_text(const std::string &path)
{
    const YAML::Node root = resolved_yaml(path);
    YAML::Emitter e;
    e << root;
    return "# The scene this run ran: " + path + ", its includes merged in.\n" + std::string(e.c_str()) + "\n";
}

}  // namespace afm
