#include "run_process.hpp"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <utility>

#include "afm_channels.h"
#include "bus_key.hpp"

namespace afm {

namespace {

// channels.yaml's channels and, for each, the programs that publish it ("*": every process).
const std::vector<std::pair<std::string, std::string>> &channel_publishers()
{
#define AFM_PUBLISHER_ROW(channel, program) {channel, program},
    static const std::vector<std::pair<std::string, std::string>> rows = {AFM_CHANNEL_PUBLISHERS(AFM_PUBLISHER_ROW)};
#undef AFM_PUBLISHER_ROW
    return rows;
}

// channels.yaml's channels and, for each, the run's programs that read it ("*": every process).
const std::vector<std::pair<std::string, std::string>> &channel_readers()
{
#define AFM_READER_ROW(channel, program) {channel, program},
    static const std::vector<std::pair<std::string, std::string>> rows = {AFM_CHANNEL_READERS(AFM_READER_ROW)};
#undef AFM_READER_ROW
    return rows;
}

// The programs a table gives `channel`, joined with ", " ("" for none).
std::string programs_of(const std::vector<std::pair<std::string, std::string>> &rows, const std::string &channel)
{
    std::string out;
    for (const auto &[ch, program] : rows)
        if (ch == channel) out += (out.empty() ? "" : ", ") + program;
    return out;
}

std::string publishers_of(const std::string &channel) { return programs_of(channel_publishers(), channel); }

// True when the table gives `channel` to program `name` (or to every process).
bool gives(const std::vector<std::pair<std::string, std::string>> &rows, const std::string &channel, const std::string &name)
{
    return std::any_of(rows.begin(), rows.end(), [&](const auto &r) { return r.first == channel && (r.second == name || r.second == "*"); });
}

// How the body ended, as its report says it (lifecycle.hpp).
std::string ended_text(int code)
{
    if (code == kExitOk) return "ok";
    if (code == kExitRunOverEarly) return "run_over_early";
    return "exit " + std::to_string(code);
}

}  // namespace

std::string channels_refusal(const std::string &name, const std::vector<std::string> &subscribes, const std::vector<std::string> &publishes)
{
    for (const auto &ch : subscribes) {
        if (publishers_of(ch).empty()) return "reads " + ch + ", which is no channel of lcmtypes/channels.yaml";
        if (!gives(channel_readers(), ch, name)) {
            const std::string who = programs_of(channel_readers(), ch);
            return "reads " + ch + ", which lcmtypes/channels.yaml does not give it (its readers: " + (who.empty() ? "none" : who) + ")";
        }
    }
    for (const auto &ch : publishes) {
        const std::string who = publishers_of(ch);
        if (who.empty()) return "publishes " + ch + ", which is no channel of lcmtypes/channels.yaml";
        if (!gives(channel_publishers(), ch, name)) return "publishes " + ch + ", which lcmtypes/channels.yaml does not give it (its publisher: " + who + ")";
    }
    return "";
}

int run_process(const char *name, const std::function<int()> &body, Lifecycle *life)
{
    pid_t launcher = 0;
    if (!bind_to_launcher(&launcher)) {
        std::fprintf(stderr, "%s: its launcher (pid %d) is gone: the run is over\n", name, static_cast<int>(launcher));
        return kExitFailure;
    }
    auto end = [life](const std::string &ended, const std::string &error) {
        if (life) life->end(ended, error);
    };
    try {
        run_key();   // the run's bus key, read once and its descriptor closed (bus_key.hpp)
        const int code = body();
        end(ended_text(code), "");
        return code;
    } catch (const InputError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        end("input_error", e.what());
        return kExitInput;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "%s: %s\n", name, e.what());
        end("failure", e.what());
        return kExitFailure;
    }
}

}  // namespace afm
