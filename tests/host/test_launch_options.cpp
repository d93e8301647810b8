// The launcher's command line (launch/options.hpp): every option parsed
// into Options; a bad value refused with one line naming the option and
// the value; the usage lists every option, from the same table.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "options.hpp"

extern "C" {
#include "unity.h"
}

using afm::launch::Options;
using afm::launch::Parsed;

void setUp() {}
void tearDown() {}

static Parsed parse(std::vector<std::string> args, Options *o)
{
    args.insert(args.begin(), "afm_launch");
    std::vector<char *> argv;
    for (auto &a : args) argv.push_back(a.data());
    return afm::launch::parse_args(static_cast<int>(argv.size()), argv.data(), o);
}

void test_every_option_is_parsed()
{
    Options o;
    const Parsed p = parse({"--scene", "s.yaml", "--out", "d", "--check", "--view", "--inject-drop", "0.25", "--kill", "1.5:fw_node",
                            "--inject-crash", "fw_node:7", "--firmware", "qemu", "--hosts", "2", "--stall-s", "9", "--quiet", "--strict",
                            "--no-verdict", "--log-window", "12", "--no-renderer", "--placement", "off"},
                           &o);
    TEST_ASSERT_EQUAL_STRING("", p.err.c_str());
    TEST_ASSERT_EQUAL(-1, p.code);
    TEST_ASSERT_EQUAL_STRING("s.yaml", o.scene_path.c_str());
    TEST_ASSERT_EQUAL_STRING("d", o.out_dir.c_str());
    TEST_ASSERT_TRUE(o.check_only && o.view && o.quiet && o.strict && o.no_verdict);
    TEST_ASSERT_EQUAL_DOUBLE(0.25, o.drop_p);
    TEST_ASSERT_EQUAL_DOUBLE(1.5, o.kill_after);
    TEST_ASSERT_EQUAL_STRING("fw_node", o.kill_name.c_str());
    TEST_ASSERT_EQUAL(7, o.crash_block);
    TEST_ASSERT_EQUAL_STRING("qemu", o.firmware.c_str());
    TEST_ASSERT_EQUAL(2, o.hosts);
    TEST_ASSERT_EQUAL_DOUBLE(9, o.stall_s);
    TEST_ASSERT_EQUAL(12, o.log_window);
    TEST_ASSERT_FALSE(o.renderer);
    TEST_ASSERT_FALSE(o.placement);
    Options spy;
    parse({"--scene", "s.yaml", "--check", "--spy"}, &spy);   // --check: no display needed
    TEST_ASSERT_TRUE(spy.spy);
}

void test_resolved_is_a_check_that_takes_no_out()
{
    Options o;
    Parsed p = parse({"--scene", "s.yaml", "--resolved"}, &o);
    TEST_ASSERT_EQUAL(-1, p.code);
    TEST_ASSERT_TRUE(o.resolved && o.check_only);
    Options with_out;
    p = parse({"--scene", "s.yaml", "--resolved", "--out", "d"}, &with_out);
    TEST_ASSERT_EQUAL(2, p.code);
    TEST_ASSERT_EQUAL_STRING("afm_launch: --resolved: prints the scene and runs nothing: it takes no --out\n", p.err.c_str());
}

void test_estimate_is_a_check_that_takes_no_out_nor_resolved()
{
    Options o;
    Parsed p = parse({"--scene", "s.yaml", "--estimate"}, &o);
    TEST_ASSERT_EQUAL(-1, p.code);
    TEST_ASSERT_TRUE(o.estimate && o.check_only && !o.resolved);
    Options with_out;
    p = parse({"--scene", "s.yaml", "--estimate", "--out", "d"}, &with_out);
    TEST_ASSERT_EQUAL(2, p.code);
    TEST_ASSERT_EQUAL_STRING("afm_launch: --estimate: prints an estimate and runs nothing: it takes no --out\n", p.err.c_str());
    Options both;
    p = parse({"--scene", "s.yaml", "--estimate", "--resolved"}, &both);
    TEST_ASSERT_EQUAL(2, p.code);
}

void test_view_fd_takes_a_descriptor_open_for_writing()
{
    const int fd = open("/dev/null", O_WRONLY | O_CLOEXEC);
    TEST_ASSERT_GREATER_THAN(2, fd);
    Options o;
    for (const auto &s : afm::launch::option_table())
        if (std::string(s.name) == "--view-fd") TEST_ASSERT_EQUAL_STRING("", s.set(std::to_string(fd), &o).c_str());
    TEST_ASSERT_EQUAL(fd, o.view_fd);
    close(fd);
}

void test_bad_values_are_refused_naming_the_option_and_the_value()
{
    const struct {
        int line;
        const char *option, *value;
    } rows[] = {
        {__LINE__, "--inject-drop", "1.5"}, {__LINE__, "--inject-drop", "lots"},   {__LINE__, "--firmware", "arm"},
        {__LINE__, "--hosts", "3"},         {__LINE__, "--placement", "maybe"},    {__LINE__, "--log-window", "-1"},
        {__LINE__, "--log-window", "8x"},   {__LINE__, "--stall-s", "soon"},       {__LINE__, "--stall-s", "0"},
        {__LINE__, "--kill", "5"},          {__LINE__, "--kill", "x:fw_node"},     {__LINE__, "--inject-crash", "sim_afm:3"},
        {__LINE__, "--inject-crash", "fw_node:"}, {__LINE__, "--view-fd", "0"},    {__LINE__, "--view-fd", "99x"},
    };
    for (const auto &r : rows) {
        Options o;
        const Parsed p = parse({"--scene", "s.yaml", "--out", "d", r.option, r.value}, &o);
        char msg[64];
        std::snprintf(msg, sizeof msg, "row at line %d", r.line);
        TEST_ASSERT_EQUAL_MESSAGE(2, p.code, msg);
        TEST_ASSERT_TRUE_MESSAGE(p.err.rfind("afm_launch: ", 0) == 0, msg);
        TEST_ASSERT_TRUE_MESSAGE(p.err.find(r.option) != std::string::npos, msg);
        const std::string shown = std::string(r.option) == "--inject-drop" && std::string(r.value) == "1.5" ? "1.5" : std::string("'") + r.value + "'";
        TEST_ASSERT_TRUE_MESSAGE(p.err.find(shown) != std::string::npos, msg);
        TEST_ASSERT_EQUAL_MESSAGE(1, std::count(p.err.begin(), p.err.end(), '\n'), msg);
    }
}

void test_a_missing_value_an_unknown_argument_and_no_scene_are_refused()
{
    Options o;
    Parsed p = parse({"--scene", "s.yaml", "--out", "d", "--stall-s"}, &o);
    TEST_ASSERT_EQUAL(2, p.code);
    TEST_ASSERT_EQUAL_STRING("afm_launch: --stall-s: needs a value (S)\n", p.err.c_str());
    p = parse({"--scene", "s.yaml", "--bogus"}, &o);
    TEST_ASSERT_EQUAL(2, p.code);
    TEST_ASSERT_EQUAL_STRING("afm_launch: --bogus: unknown option (afm_launch --help lists them)\n", p.err.c_str());
    Options none;
    p = parse({"--out", "d"}, &none);
    TEST_ASSERT_EQUAL(2, p.code);
    TEST_ASSERT_EQUAL_STRING("afm_launch: --scene FILE: required (afm_launch --help: the usage)\n", p.err.c_str());
    Options no_out;
    p = parse({"--scene", "s.yaml"}, &no_out);
    TEST_ASSERT_EQUAL(2, p.code);
    TEST_ASSERT_EQUAL_STRING("afm_launch: --out DIR: required unless --check (afm_launch --help: the usage)\n", p.err.c_str());
    p = parse({"--scene", "s.yaml", "--view-fd", "1"}, &none);
    TEST_ASSERT_EQUAL(2, p.code);
}

void test_help_prints_the_usage_which_lists_every_option()
{
    Options o;
    const Parsed p = parse({"--help"}, &o);
    TEST_ASSERT_EQUAL(0, p.code);
    TEST_ASSERT_EQUAL_STRING(afm::launch::usage().c_str(), p.out.c_str());
    const std::string u = afm::launch::usage();
    for (const auto &s : afm::launch::option_table()) {
        const bool listed = s.section != nullptr;
        const std::string as_shown = std::string(listed ? "\n  " : "") + s.name + (s.shown ? std::string(" ") + s.shown : "");
        TEST_ASSERT_TRUE_MESSAGE(u.find(as_shown) != std::string::npos, s.name);
        TEST_ASSERT_TRUE_MESSAGE(!listed || std::string(s.help).find('\t') == std::string::npos, s.name);
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_every_option_is_parsed);
    RUN_TEST(test_resolved_is_a_check_that_takes_no_out);
    RUN_TEST(test_estimate_is_a_check_that_takes_no_out_nor_resolved);
    RUN_TEST(test_view_fd_takes_a_descriptor_open_for_writing);
    RUN_TEST(test_bad_values_are_refused_naming_the_option_and_the_value);
    RUN_TEST(test_a_missing_value_an_unknown_argument_and_no_scene_are_refused);
    RUN_TEST(test_help_prints_the_usage_which_lists_every_option);
    return UNITY_END();
}
