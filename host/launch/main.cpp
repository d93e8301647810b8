// afm_launch: runs one scene (launch.hpp: Launch, and the steps below in
// order; options.hpp: the command line).
#include "launch.hpp"

int main(int argc, char **argv)
{
    using namespace afm::launch;

    Options o;
    if (const int code = afm::cli::answer(parse_args(argc, argv, &o)); code >= 0) return code;   // --help, or a refusal
    Launch run(o);
    if (const int code = run.check_scene(); code >= 0) return code;
    if (o.check_only) return run.check_out() < 0 ? 0 : 2;   // with --out: may a run take it
    if (const int code = run.prepare(); code >= 0) return code;
    if (const int code = run.start(); code >= 0) return code;
    run.supervise();
    run.stop();
    return run.finish();
}
