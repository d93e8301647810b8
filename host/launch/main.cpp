// afm_launch: runs one scene (launch.hpp: Launch, and the steps below in
// order; options.hpp: the command line).
#include <cstdio>

#include "launch.hpp"

int main(int argc, char **argv)
{
    using namespace afm::launch;

    Options o;
    const Parsed parsed = parse_args(argc, argv, &o);
    std::fputs(parsed.out.c_str(), stdout);
    std::fputs(parsed.err.c_str(), stderr);
    if (parsed.code >= 0) return parsed.code;
    Launch run(o);
    if (const int code = run.check_scene(); code >= 0) return code;
    if (o.check_only) return run.check_out() < 0 ? 0 : 2;   // with --out: may a run take it
    if (const int code = run.prepare(); code >= 0) return code;
    if (const int code = run.start(); code >= 0) return code;
    run.supervise();
    run.stop();
    return run.finish();
}
