// The scan client (host/image/scan_client.hpp) on a bus of its own (LCM's
// memq:// provider): it asks again for the lines still missing only once
// retry_ms passed with neither a request nor a line, so a scan the
// simulator takes longer than retry_ms to serve is not asked for again
// while its lines come (a 512-line scan was asked 14 times so, issue 49).
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <thread>

#include "afm/scan_req_t.hpp"
#include "afm_channels.h"
#include "scan_client.hpp"

extern "C" {
#include "unity.h"
}

void setUp() {}
void tearDown() {}

namespace {

struct Asked {
    int requests = 0, first = -1, n = 0;
    void on(const lcm::ReceiveBuffer *, const std::string &, const afm::scan_req_t *m)
    {
        ++requests;
        first = m->first_line;
        n = m->n_lines;
    }
};

afm::scan_line_t line(int j)
{
    afm::scan_line_t m{};
    m.req_id = 7;
    m.line = j;
    m.n_lines = 3;
    m.n = 2;
    m.height_nm = {1.0, 2.0};
    m.defl_v = m.lat_v = {0.0, 0.0};
    return m;
}

void sleep_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

}  // namespace

void test_a_scan_whose_lines_come_is_not_asked_again()
{
    lcm::LCM lc{"memq://"};
    Asked asked;
    lc.subscribe(AFM_CH_AFM_SCAN_REQ, &Asked::on, &asked);
    afm::ScanClient c(lc);
    c.start(7, afm::ScanRegion{0, 0, 100, 150, 2, 3});
    while (lc.handleTimeout(0) > 0) {}
    TEST_ASSERT_EQUAL_INT(1, asked.requests);
    // a line every 60 ms, the retry at 100 ms: the scan is coming, no retry
    for (int j = 0; j < 2; ++j) {
        sleep_ms(60);
        c.on_line(line(j));
        c.retry(100);
    }
    while (lc.handleTimeout(0) > 0) {}
    TEST_ASSERT_EQUAL_INT(1, asked.requests);
    // then nothing for 100 ms: the missing line is asked again, alone
    sleep_ms(110);
    c.retry(100);
    while (lc.handleTimeout(0) > 0) {}
    TEST_ASSERT_EQUAL_INT(2, asked.requests);
    TEST_ASSERT_EQUAL_INT(2, asked.first);
    TEST_ASSERT_EQUAL_INT(1, asked.n);
    TEST_ASSERT_TRUE(c.on_line(line(2)));
    TEST_ASSERT_FALSE(c.busy());
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_a_scan_whose_lines_come_is_not_asked_again);
    return UNITY_END();
}
