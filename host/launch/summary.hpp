// The run's summary on stdout, read from its record (run_record.hpp):
// speed, the loop, fidelity, the planner, the card on its board, the page's
// bridge, the two hosts' link, the folder and the verdict.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace afm::launch {

// The summary of a run that completed; hosts_line: Hosts::summary() ("" on one namespace).
void print_summary(const nlohmann::json &run, double wall_s, int64_t messages, const std::string &hosts_line, const std::string &out);

}  // namespace afm::launch
