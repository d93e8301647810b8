// The command line of every host program (common/command_line.hpp): a
// table read into a program's options struct; each refusal one line in one
// form, "PROG: --opt: why (got 'value')", exit kExitInput; --help the usage
// from the same table, exit 0; the readers' ranges, ends included or not.
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "command_line.hpp"

extern "C" {
#include "unity.h"
}

using afm::cli::Parsed;

void setUp() {}
void tearDown() {}

namespace {

struct Opts {
    std::string input, scene, mode = "fast";
    bool quiet = false, color = true;
    long long blocks = 8;
    int port = 0, count = 1;
    double p = 0, gain = 1;
    std::vector<int> cpus;
};

const afm::cli::CommandLine<Opts> kCli = {
    "prog",
    "usage: prog INPUT --scene FILE [options]\n",
    {
        {{"INPUT", nullptr, nullptr, nullptr, true}, afm::cli::text(&Opts::input)},
        {{"--scene", "FILE", nullptr, nullptr, true}, afm::cli::text(&Opts::scene)},
        {{"--quiet", nullptr, "options:", "say less"}, afm::cli::flag(&Opts::quiet)},
        {{"--mode", "fast|slow", "options:", "how"}, afm::cli::choice(&Opts::mode, {"fast", "slow"})},
        {{"--blocks", "N", "options:", "blocks ahead,\nat least 1"}, afm::cli::whole(&Opts::blocks, 1, 64, "a number of blocks")},
        {{"--port", "N", "options:", "a port"}, afm::cli::whole(&Opts::port, 0, 65535)},
        {{"--count", "N", "options:", "as many as an int holds"}, afm::cli::whole(&Opts::count, 1)},
        {{"--p", "P", "more options:", "a probability"}, afm::cli::number(&Opts::p, afm::cli::in_range(0, 1, true), "a probability")},
        {{"--gain", "G", "more options:", "above zero"}, afm::cli::number(&Opts::gain, afm::cli::above(0))},
        {{"--cpus", "LIST", "more options:", "where"}, afm::cli::cpus(&Opts::cpus)},
        {{"--no-color", nullptr, "more options:", "plain"}, afm::cli::flag(&Opts::color, false)},
    },
    [](const Opts &o) { return o.quiet && o.mode == "slow" ? std::string("--quiet: goes with --mode fast") : std::string(); }};

Parsed parse(std::vector<std::string> args, Opts *o)
{
    args.insert(args.begin(), "prog");
    std::vector<char *> argv;
    for (auto &a : args) argv.push_back(a.data());
    return kCli.parse(static_cast<int>(argv.size()), argv.data(), o);
}

// The one line of a refusal, and its code.
void assert_refused(const std::vector<std::string> &args, const char *line, int at)
{
    Opts o;
    const Parsed p = parse(args, &o);
    char msg[64];
    std::snprintf(msg, sizeof msg, "row at line %d", at);
    TEST_ASSERT_EQUAL_MESSAGE(afm::kExitInput, p.code, msg);
    TEST_ASSERT_EQUAL_STRING_MESSAGE(line, p.err.c_str(), msg);
    TEST_ASSERT_EQUAL_STRING_MESSAGE("", p.out.c_str(), msg);
}

}  // namespace

void test_every_kind_of_option_is_read()
{
    Opts o;
    const Parsed p = parse({"in.log", "--scene", "s.yaml", "--quiet", "--mode=fast", "--blocks", "64", "--port", "0", "--count",
                            "2147483647", "--p", "0",
                            "--gain=2.5", "--cpus", "0,2-3", "--no-color"},
                           &o);
    TEST_ASSERT_EQUAL(-1, p.code);
    TEST_ASSERT_EQUAL_STRING("", p.err.c_str());
    TEST_ASSERT_EQUAL_STRING("in.log", o.input.c_str());
    TEST_ASSERT_EQUAL_STRING("s.yaml", o.scene.c_str());
    TEST_ASSERT_TRUE(o.quiet);
    TEST_ASSERT_FALSE(o.color);
    TEST_ASSERT_EQUAL(64, o.blocks);
    TEST_ASSERT_EQUAL(0, o.port);
    TEST_ASSERT_EQUAL(2147483647, o.count);
    TEST_ASSERT_EQUAL_DOUBLE(0, o.p);
    TEST_ASSERT_EQUAL_DOUBLE(2.5, o.gain);
    TEST_ASSERT_TRUE((o.cpus == std::vector<int>{0, 2, 3}));
}

// A value option takes the next argument whatever it begins with; the
// positional argument may stand anywhere.
void test_a_value_is_the_next_argument_whatever_it_is()
{
    Opts o;
    TEST_ASSERT_EQUAL(-1, parse({"--scene", "-h", "in"}, &o).code);
    TEST_ASSERT_EQUAL_STRING("-h", o.scene.c_str());
    TEST_ASSERT_EQUAL_STRING("in", o.input.c_str());
    Opts e;
    TEST_ASSERT_EQUAL(-1, parse({"--scene", "s", "--cpus", "", "in"}, &e).code);   // "": no CPU
    TEST_ASSERT_TRUE(e.cpus.empty());
}

void test_a_repeated_option_takes_its_last_value()
{
    Opts o;
    TEST_ASSERT_EQUAL(-1, parse({"in", "--scene", "a", "--blocks", "3", "--scene", "b", "--blocks", "5", "--quiet", "--quiet"}, &o).code);
    TEST_ASSERT_EQUAL_STRING("b", o.scene.c_str());
    TEST_ASSERT_EQUAL(5, o.blocks);
}

void test_help_answers_the_usage_and_zero()
{
    for (const char *h : {"-h", "--help"}) {
        Opts o;
        const Parsed p = parse({"--blocks", "3", h, "--bogus"}, &o);   // before anything after it is read
        TEST_ASSERT_EQUAL(afm::kExitOk, p.code);
        TEST_ASSERT_EQUAL_STRING(kCli.usage().c_str(), p.out.c_str());
        TEST_ASSERT_EQUAL_STRING("", p.err.c_str());
    }
}

void test_the_usage_lists_each_section_in_order_from_the_table()
{
    const std::string u = kCli.usage();
    TEST_ASSERT_EQUAL_STRING("usage: prog INPUT --scene FILE [options]\n"
                             "options:\n"
                             "  --quiet            say less\n"
                             "  --mode fast|slow   how\n"
                             "  --blocks N         blocks ahead,\n"
                             "                     at least 1\n"
                             "  --port N           a port\n"
                             "  --count N          as many as an int holds\n"
                             "more options:\n"
                             "  --p P              a probability\n"
                             "  --gain G           above zero\n"
                             "  --cpus LIST        where\n"
                             "  --no-color         plain\n",
                             u.c_str());
}

void test_every_refusal_is_one_line_naming_the_option_and_the_value()
{
    const struct {
        int line;
        std::vector<std::string> args;
        const char *err;
    } rows[] = {
        {__LINE__, {"in", "--scene", "s", "--bogus"}, "prog: --bogus: unknown option (prog --help lists them)\n"},
        {__LINE__, {"in", "--scene", "s", "--bogus=1"}, "prog: --bogus: unknown option (prog --help lists them)\n"},
        {__LINE__, {"in", "--scene", "s", "-x"}, "prog: -x: unknown option (prog --help lists them)\n"},
        {__LINE__, {"in", "--scene"}, "prog: --scene: needs a value (FILE)\n"},
        {__LINE__, {"in", "--scene", "s", "--blocks"}, "prog: --blocks: needs a value (N)\n"},
        {__LINE__, {"in", "--scene", "s", "--quiet=yes"}, "prog: --quiet: takes no value (got 'yes')\n"},
        {__LINE__, {"in", "--scene", "s", "--quiet="}, "prog: --quiet: takes no value (got '')\n"},
        {__LINE__, {"in", "--scene", ""}, "prog: --scene: wants a value, not an empty word (got '')\n"},
        {__LINE__, {"", "--scene", "s"}, "prog: INPUT: wants a value, not an empty word (got '')\n"},
        {__LINE__, {"in", "--scene", "s", "--mode", "medium"}, "prog: --mode: wants fast or slow (got 'medium')\n"},
        {__LINE__, {"in", "--scene", "s", "--blocks", "0"}, "prog: --blocks: wants a number of blocks in [1, 64] (got '0')\n"},
        {__LINE__, {"in", "--scene", "s", "--blocks", "65"}, "prog: --blocks: wants a number of blocks in [1, 64] (got '65')\n"},
        {__LINE__, {"in", "--scene", "s", "--blocks", "8x"}, "prog: --blocks: wants a number of blocks in [1, 64] (got '8x')\n"},
        {__LINE__, {"in", "--scene", "s", "--blocks", " 8"}, "prog: --blocks: wants a number of blocks in [1, 64] (got ' 8')\n"},
        {__LINE__, {"in", "--scene", "s", "--blocks", "99999999999999999999"},
         "prog: --blocks: wants a number of blocks in [1, 64] (got '99999999999999999999')\n"},
        {__LINE__, {"in", "--scene", "s", "--port", "-1"}, "prog: --port: wants a whole number in [0, 65535] (got '-1')\n"},
        {__LINE__, {"in", "--scene", "s", "--count", "2147483648"}, "prog: --count: wants a whole number >= 1 (got '2147483648')\n"},
        {__LINE__, {"in", "--scene", "s", "--p", "1"}, "prog: --p: wants a probability in [0, 1) (got '1')\n"},
        {__LINE__, {"in", "--scene", "s", "--p", "-0.1"}, "prog: --p: wants a probability in [0, 1) (got '-0.1')\n"},
        {__LINE__, {"in", "--scene", "s", "--p", "nan"}, "prog: --p: wants a probability in [0, 1) (got 'nan')\n"},
        {__LINE__, {"in", "--scene", "s", "--gain", "0"}, "prog: --gain: wants a number > 0 (got '0')\n"},
        {__LINE__, {"in", "--scene", "s", "--gain", "inf"}, "prog: --gain: wants a number > 0 (got 'inf')\n"},
        {__LINE__, {"in", "--scene", "s", "--gain", ""}, "prog: --gain: wants a number > 0 (got '')\n"},
        {__LINE__, {"in", "--scene", "s", "--cpus", "1-0"}, "prog: --cpus: wants a CPU list such as 1 or 0-1 (got '1-0')\n"},
        {__LINE__, {"in", "--scene", "s", "--cpus", "0,"}, "prog: --cpus: wants a CPU list such as 1 or 0-1 (got '0,')\n"},
        {__LINE__, {"in", "--scene", "s", "out"}, "prog: INPUT: one only (got 'out' after 'in')\n"},
        {__LINE__, {"--scene", "s"}, "prog: INPUT: required (prog --help: the usage)\n"},
        {__LINE__, {"in"}, "prog: --scene FILE: required (prog --help: the usage)\n"},
        {__LINE__, {}, "prog: INPUT: required (prog --help: the usage)\n"},
        {__LINE__, {"in", "--scene", "s", "--quiet", "--mode", "slow"}, "prog: --quiet: goes with --mode fast\n"},
    };
    for (const auto &r : rows) assert_refused(r.args, r.err, r.line);
}

// A refused value leaves the options as they were.
void test_a_refused_value_is_not_stored()
{
    Opts o;
    parse({"in", "--scene", "s", "--blocks", "99"}, &o);
    TEST_ASSERT_EQUAL(8, o.blocks);
    parse({"in", "--scene", "s", "--cpus", "2", "--cpus", "x"}, &o);
    TEST_ASSERT_TRUE((o.cpus == std::vector<int>{2}));
}

// A program without a positional argument refuses a word.
void test_a_word_without_a_positional_is_refused()
{
    struct Two {
        bool a = false;
    };
    const afm::cli::CommandLine<Two> cli = {"two", "usage: two [--a]\n", {{{"--a", nullptr, nullptr, nullptr}, afm::cli::flag(&Two::a)}}};
    std::string w = "word", name = "two";
    char *argv[] = {name.data(), w.data()};
    Two t;
    const Parsed p = cli.parse(2, argv, &t);
    TEST_ASSERT_EQUAL(afm::kExitInput, p.code);
    TEST_ASSERT_EQUAL_STRING("two: 'word': not an option (two --help lists them)\n", p.err.c_str());
}

void test_the_readers_ends()
{
    double x = -1;
    TEST_ASSERT_EQUAL_STRING("", afm::cli::read_number("0", afm::cli::at_least(0), &x).c_str());
    TEST_ASSERT_EQUAL_STRING("wants a number >= 0", afm::cli::read_number("-1e-9", afm::cli::at_least(0), &x).c_str());
    TEST_ASSERT_EQUAL_STRING("", afm::cli::read_number("0.999", afm::cli::in_range(0, 1, true), &x).c_str());
    TEST_ASSERT_EQUAL_STRING("", afm::cli::read_number("1", afm::cli::in_range(0, 1), &x).c_str());
    TEST_ASSERT_EQUAL_DOUBLE(1, x);
    long long n = 0;
    TEST_ASSERT_EQUAL_STRING("", afm::cli::read_whole("-1", -1, 5, &n).c_str());
    TEST_ASSERT_EQUAL(-1, n);
    TEST_ASSERT_EQUAL_STRING("wants a whole number >= -1", afm::cli::read_whole("-2", -1, std::numeric_limits<long long>::max(), &n).c_str());
    TEST_ASSERT_EQUAL_STRING("wants a whole number", afm::cli::read_whole("1.5", std::numeric_limits<long long>::min(),
                                                                       std::numeric_limits<long long>::max(), &n).c_str());
    std::string s = "kept";
    TEST_ASSERT_EQUAL_STRING("wants a, b or c", afm::cli::read_choice("d", {"a", "b", "c"}, &s).c_str());
    TEST_ASSERT_EQUAL_STRING("kept", s.c_str());
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_every_kind_of_option_is_read);
    RUN_TEST(test_a_value_is_the_next_argument_whatever_it_is);
    RUN_TEST(test_a_repeated_option_takes_its_last_value);
    RUN_TEST(test_help_answers_the_usage_and_zero);
    RUN_TEST(test_the_usage_lists_each_section_in_order_from_the_table);
    RUN_TEST(test_every_refusal_is_one_line_naming_the_option_and_the_value);
    RUN_TEST(test_a_refused_value_is_not_stored);
    RUN_TEST(test_a_word_without_a_positional_is_refused);
    RUN_TEST(test_the_readers_ends);
    return UNITY_END();
}
