// Test helper of tests/py/test_lcm_walk.py: decodes standard input as the
// type its argument names (lcm-gen's C++ class) and prints what the walk
// generated from the .lcm files (afm_lcm_walk.hpp) visits, one field a
// line: its name path and its unit ("-" when its comment states none).
// Exit 2 on an unknown type or bytes that do not decode.
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "afm_lcm_walk.hpp"

namespace {

struct Print {
    template <class T>
    void operator()(const std::string &name, const T &, const char *unit)
    {
        std::printf("%s %s\n", name.c_str(), *unit ? unit : "-");
    }
};

template <class M>
int walk_stdin(const std::vector<uint8_t> &d, const char *type)
{
    M m;
    if (m.decode(d.data(), 0, static_cast<int>(d.size())) < 0) {
        std::fprintf(stderr, "lcm_walk_names: %zu bytes on standard input do not decode as %s\n", d.size(), type);
        return 2;
    }
    Print p;
    afm::lcm_walk::walk(m, "", p);
    return 0;
}

}  // namespace

int main(int argc, char **argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: lcm_walk_names TYPE < ENCODED_MESSAGE\n");
        return 2;
    }
    const std::string type = argv[1];
    const std::vector<uint8_t> d((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
#define AFM_WALK_IF(T) \
    if (type == #T) return walk_stdin<afm::T>(d, #T);
    AFM_LCM_WALK_TYPES(AFM_WALK_IF)
#undef AFM_WALK_IF
    std::fprintf(stderr, "lcm_walk_names: type '%s' is not one of lcmtypes/*.lcm\n", type.c_str());
    return 2;
}
