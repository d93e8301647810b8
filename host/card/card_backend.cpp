// The host build of the card behind CardBackend (card_backend.hpp): the
// firmware library called in this process.
#include "card_backend.hpp"

#include <vector>

#include "command_line.hpp"

namespace afm {
namespace {

class HostCard final : public CardBackend {
public:
    fw_rule_t init(const fw_card_config_t &cfg, const fw_card_storage_t &st) override
    {
        fw_rule_t rule = FW_RULE_OK;
        if (fw_card_init(&card_, &cfg, &st, &rule) != FW_OK) return rule == FW_RULE_OK ? FW_RULE_NULL_POINTER : rule;
        particles_.resize(static_cast<std::size_t>(cfg.n_particles));
        wires_.resize(static_cast<std::size_t>(cfg.n_wires));
        models_.particles = particles_.data();
        models_.particle_capacity = cfg.n_particles;
        models_.wires = wires_.data();
        models_.wire_capacity = cfg.n_wires;
        take();
        return FW_RULE_OK;
    }
    fw_status_t step_block(const fw_card_in_t &in, fw_card_out_t *out) override
    {
        const fw_status_t s = fw_card_step_block(&card_, &in, out);
        take();
        return s;
    }
    fw_status_t fix(bool place, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out) override
    {
        const fw_status_t s = place ? fw_card_place(&card_, object_id, scan_pm, out) : fw_card_fix(&card_, object_id, scan_pm, out);
        take();
        return s;
    }
    const fw_models_t &models() const override { return models_; }
    nlohmann::json report() const override { return {{"firmware", "host"}}; }

private:
    fw_card_t card_{};
    fw_models_t models_{};
    std::vector<fw_models_particle_t> particles_;
    std::vector<fw_models_wire_t> wires_;
    void take()
    {
        if (fw_models_take(&card_, &models_) != FW_OK) throw std::logic_error("fw_models_take: the card holds more objects than its configuration");
    }
};

}  // namespace

std::string read_firmware(const std::string &v, std::string *out) { return cli::read_choice(v, {"host", "qemu"}, out); }

std::unique_ptr<CardBackend> make_card_backend(const CardBackendOptions &o)
{
    std::string firmware;
    if (const std::string why = read_firmware(o.firmware, &firmware); !why.empty())
        throw std::invalid_argument("--firmware: " + why + " (got '" + o.firmware + "')");
    if (firmware == "host") return std::make_unique<HostCard>();
    return make_board_backend(o);
}

}  // namespace afm
