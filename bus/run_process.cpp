#include "run_process.hpp"

#include <cstdio>
#include <exception>

#include "bus_key.hpp"

namespace afm {

int run_process(const char *name, const std::function<int()> &body)
{
    pid_t launcher = 0;
    if (!bind_to_launcher(&launcher)) {
        std::fprintf(stderr, "%s: its launcher (pid %d) is gone: the run is over\n", name, static_cast<int>(launcher));
        return kExitFailure;
    }
    try {
        run_key();   // the run's bus key, read once and its descriptor closed (bus_key.hpp)
        return body();
    } catch (const InputError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return kExitInput;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "%s: %s\n", name, e.what());
        return kExitFailure;
    }
}

}  // namespace afm
