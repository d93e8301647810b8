// afm_launch: runs one scene (launch.hpp: Launch, and the steps below in
// order; options.hpp: the command line). --resolved: the scene checked, then
// printed as a run keeps it (scene.hpp: resolved_scene_text), exit 0.
#include <cstdio>
#include <filesystem>

#include "launch.hpp"

namespace {

// The scene as a run keeps it, on stdout: 0, else 2 (said on stderr).
int print_resolved(const std::string &path)
{
    try {
        const std::string text = afm::resolved_scene_text(std::filesystem::canonical(path).string());
        return std::fwrite(text.data(), 1, text.size(), stdout) == text.size() && std::fflush(stdout) == 0 ? 0 : 2;
    } catch (const std::exception &e) {   // the file gone since its check, or no longer a scene
        std::fprintf(stderr, "afm_launch: --resolved: %s\n", e.what());
        return 2;
    }
}

}  // namespace

int main(int argc, char **argv)
{
    using namespace afm::launch;

    Options o;
    if (const int code = afm::cli::answer(parse_args(argc, argv, &o)); code >= 0) return code;   // --help, or a refusal
    Launch run(o);
    if (const int code = run.check_scene(); code >= 0) return code;
    if (o.resolved) return print_resolved(o.scene_path);
    if (o.estimate) return 0;   // check_scene printed it
    if (o.check_only) return run.check_out() < 0 ? 0 : 2;   // with --out: may a run take it
    if (const int code = run.prepare(); code >= 0) return code;
    if (const int code = run.start(); code >= 0) return code;
    run.supervise();
    run.stop();
    return run.finish();
}
