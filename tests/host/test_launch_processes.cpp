// The run's processes as one table (launch/processes.hpp): the argv each
// gets from the options and the run's folder, what --view, --no-renderer,
// --log-window and --spy change, and on two hosts the namespaces each
// enters, its drop of what entering gave and its link.
#include <algorithm>
#include <string>
#include <vector>

#include "processes.hpp"

extern "C" {
#include "unity.h"
}

using afm::launch::Options;
using afm::launch::Process;
using afm::launch::RunPlaces;

void setUp() {}
void tearDown() {}

static afm::launch::Hosts one, two;
static const afm::Placement none;

static RunPlaces places(const afm::launch::Hosts &h)
{
    return {"/b", "/o", "/o/scene.yaml", "udpm://bus", 0, &h, &none, "4242", "/lcm", "/types.jar", "/src/run/spy.sh"};
}

static std::vector<std::string> names(const std::vector<Process> &t)
{
    std::vector<std::string> n;
    for (const auto &p : t) n.push_back(p.name);
    return n;
}

static bool has(const std::vector<std::string> &v, const std::string &s) { return std::find(v.begin(), v.end(), s) != v.end(); }

void test_the_default_run_is_four_processes_with_their_argv()
{
    const auto t = afm::launch::run_processes(Options{}, places(one));
    TEST_ASSERT_TRUE((names(t) == std::vector<std::string>{"sim_afm", "fw_node", "operator", "renderer"}));
    const std::vector<std::string> sim = {"/b/../sim_afm/sim_afm", "--scene", "/o/scene.yaml", "--out", "/o", "--inject-drop", "0.000000"};
    TEST_ASSERT_TRUE(t[0].argv == sim);
    const std::vector<std::string> fw = {"/b/fw_node", "--scene", "/o/scene.yaml", "--out", "/o", "--crash-at-block", "-1", "--firmware", "host"};
    TEST_ASSERT_TRUE(t[1].argv == fw);
    TEST_ASSERT_TRUE((t[2].argv == std::vector<std::string>{"/b/operator", "--scene", "/o/scene.yaml", "--out", "/o"}));
    TEST_ASSERT_TRUE((t[3].argv == std::vector<std::string>{"/b/renderer", "--scene", "/o/scene.yaml", "--out", "/o"}));
    for (const auto &p : t) {
        TEST_ASSERT_TRUE(p.role == Process::Role::run);
        TEST_ASSERT_EQUAL_STRING(("/o/logs/" + p.name + ".log").c_str(), p.log.c_str());
        TEST_ASSERT_TRUE(p.env == std::vector<std::string>{"LCM_DEFAULT_URL=udpm://bus"});
        TEST_ASSERT_EQUAL(afm::launch::kBusProcessNice, p.nice);
        TEST_ASSERT_TRUE(p.key);
        TEST_ASSERT_FALSE(p.view_fd);
        TEST_ASSERT_EQUAL(-1, p.entry.ns_pid);
    }
    TEST_ASSERT_TRUE((afm::launch::run_process_names(Options{}) == names(t)));
}

void test_view_adds_view_frames_to_the_renderer_only()
{
    Options o;
    o.view = true;
    const auto t = afm::launch::run_processes(o, places(one));
    TEST_ASSERT_EQUAL_STRING("--view-frames", afm::launch::find_process(t, "renderer")->argv.back().c_str());
    for (const char *n : {"sim_afm", "fw_node", "operator"}) TEST_ASSERT_FALSE(has(afm::launch::find_process(t, n)->argv, "--view-frames"));
}

void test_no_renderer_has_no_renderer_and_tells_the_simulator()
{
    Options o;
    o.renderer = false;
    const auto t = afm::launch::run_processes(o, places(one));
    TEST_ASSERT_NULL(afm::launch::find_process(t, "renderer"));
    TEST_ASSERT_TRUE(has(afm::launch::find_process(t, "sim_afm")->argv, "--no-renderer"));
    TEST_ASSERT_FALSE(has(afm::launch::run_process_names(o), "renderer"));
}

void test_options_reach_their_process()
{
    Options o;
    o.drop_p = 0.5;
    o.crash_block = 40;
    o.firmware = "qemu";
    RunPlaces p = places(one);
    p.log_window = 16;
    const auto t = afm::launch::run_processes(o, p);
    const auto &sim = afm::launch::find_process(t, "sim_afm")->argv;
    TEST_ASSERT_TRUE((std::vector<std::string>(sim.begin() + 5, sim.end()) ==
                      std::vector<std::string>{"--inject-drop", "0.500000", "--follow-log", "/o/bus.lcmlog", "--log-window", "16"}));
    const auto &fw = afm::launch::find_process(t, "fw_node")->argv;
    TEST_ASSERT_EQUAL_STRING("40", fw[6].c_str());
    TEST_ASSERT_EQUAL_STRING("qemu", fw[8].c_str());
}

void test_spy_comes_first_as_an_observer_without_the_key()
{
    Options o;
    o.spy = true;
    const auto t = afm::launch::run_processes(o, places(one));
    TEST_ASSERT_EQUAL_STRING("lcm-spy", t[0].name.c_str());
    TEST_ASSERT_TRUE(t[0].role == Process::Role::observer);
    TEST_ASSERT_FALSE(t[0].key);
    TEST_ASSERT_EQUAL(0, t[0].nice);
    TEST_ASSERT_TRUE((t[0].argv == std::vector<std::string>{"/src/run/spy.sh", "--lcm-url=udpm://bus"}));
    TEST_ASSERT_TRUE(has(t[0].env, "CLASSPATH=/types.jar"));
    TEST_ASSERT_TRUE(has(t[0].env, "AFM_LCM_BIN=/lcm"));
    TEST_ASSERT_EQUAL(4, std::count_if(t.begin(), t.end(), [](const Process &p) { return p.role == Process::Role::run; }));
}

void test_two_hosts_enter_the_afm_namespace_and_drop_what_it_gave()
{
    two.count = 2;
    two.afm_ns_pid = 4321;
    two.drop_caps = "/r/drop_caps.sh";
    const auto t = afm::launch::run_processes(Options{}, places(two));
    TEST_ASSERT_EQUAL(4, t.size());
    for (const auto &p : t) {
        TEST_ASSERT_EQUAL_STRING("/r/drop_caps.sh", p.argv[0].c_str());
        TEST_ASSERT_EQUAL(4321, p.entry.ns_pid);
        TEST_ASSERT_EQUAL(p.name == "sim_afm", p.entry.net);   // only the simulator in the afm network namespace
        TEST_ASSERT_TRUE(has(p.env, std::string("AFM_BUS_LINK=") + (p.name == "sim_afm" ? "vafm" : "vhost")));
        TEST_ASSERT_TRUE(has(p.env, "AFM_PARENT_UDP_PORTS=4242"));
    }
    TEST_ASSERT_TRUE(has(afm::launch::find_process(t, "sim_afm")->argv, "--resend-ms"));
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_default_run_is_four_processes_with_their_argv);
    RUN_TEST(test_view_adds_view_frames_to_the_renderer_only);
    RUN_TEST(test_no_renderer_has_no_renderer_and_tells_the_simulator);
    RUN_TEST(test_options_reach_their_process);
    RUN_TEST(test_spy_comes_first_as_an_observer_without_the_key);
    RUN_TEST(test_two_hosts_enter_the_afm_namespace_and_drop_what_it_gave);
    return UNITY_END();
}
