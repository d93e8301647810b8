// CardBackend: where the card runs, behind one interface, so that CardNode
// (card_node.hpp), the one adapter between the bus and the card's structs,
// is the same code for both builds (docs/pil.md):
//  - host: the firmware library linked into this process (fw_card_* called
//    directly), as fw_node has always run it;
//  - qemu: the same firmware sources built for the mps2-an386 board
//    (board/afm_board.c, afm_board.elf) under qemu-system-arm with -icount
//    shift=0; every call crosses to the board and back over two host FIFOs
//    (semihosting), each struct field by field (fw_marshal.h).
// Both answer each call with the card's models after it (fw_models.h): the
// adapter reads the card's particles, wires, trenches, drift and interlock
// only there.
#pragma once

extern "C" {
#include "fw_card.h"
#include "fw_models.h"
}

#include <nlohmann/json.hpp>

#include <memory>
#include <stdexcept>
#include <string>

namespace afm {

struct CardBackendOptions {
    std::string firmware = "host";   // host | qemu
    std::string board_elf;           // qemu: the board's image ("" : the build's, AFM_BOARD_ELF)
    std::string board_log;           // qemu: the board's console output goes here ("" : a file in the link's folder)
    double block_hz = 1000;          // for the budget in the report
    int samples_per_block = 1;
};

// A failure of the board: it did not start, died, hung or answered
// nonsense. The message names the board, the block and its last output.
struct BoardError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class CardBackend {
public:
    virtual ~CardBackend() = default;
    // fw_card_init on the configuration and storage's capacities; the rule broken (FW_RULE_OK: running).
    virtual fw_rule_t init(const fw_card_config_t &cfg, const fw_card_storage_t &st) = 0;
    virtual fw_status_t step_block(const fw_card_in_t &in, fw_card_out_t *out) = 0;
    // fw_card_place when place, else fw_card_fix.
    virtual fw_status_t fix(bool place, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out) = 0;
    // The card's models after the last call (valid until the next).
    virtual const fw_models_t &models() const = 0;
    // What ran, and on the board its cost (run.json card.board).
    virtual nlohmann::json report() const = 0;
    // Throws when the card can no longer answer (the board's emulator has
    // exited), naming it, between blocks too: a board killed while the
    // run waits for its first block is named then, not as another
    // process's stall. The card in this process is always alive.
    virtual void check_alive() {}
};

// --firmware's value, "host" or "qemu", checked and stored: "" when taken,
// else why (common/command_line.hpp's form). The one check of it: fw_node,
// afm_replay, the launcher and make_card_backend call it.
std::string read_firmware(const std::string &v, std::string *out);

// "host" or "qemu" (BoardError when the board does not start; std::invalid_argument for another name).
std::unique_ptr<CardBackend> make_card_backend(const CardBackendOptions &o);
std::unique_ptr<CardBackend> make_board_backend(const CardBackendOptions &o);   // card_board.cpp

}  // namespace afm
