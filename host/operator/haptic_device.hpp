// The operator's side of the force loop: the haptic device (a Phantom-class
// joystick, operator.haptic) and the hand that holds its stylus
// (operator.hand), integrated once per block in lockstep.
//
// The loop. The card renders g F_tip on the stylus (HAPTIC_FORCE: g the
// card's gain in whole uN/pN, clamped per axis to max_force_N); the device
// adds its own damping b; the hand pulls the stylus towards where the
// operator means it to be with a spring-damper (K_h, B_h) and the stylus and
// hand have mass m. The stylus position is the pose (joy = x / half_range).
// The pose of block n+1 is the stylus at the end of block n; the card
// commands the piezo from it in block n+1, so its force is measured in block
// n+2 and pushes on the stylus over block n+3: the force lags the position
// it answers by d = 2 blocks, held for one (zero-order hold).
//
//
// The bound on the card's gain that keeps this loop passive is the card's
// (card/haptic_bound.hpp). Beyond it the device's passivity observer and
// controller (Hannaford and Ryu 2002) sum the energy the stylus gives the
// device and, when the device has given back more than it took, add exactly
// the damping that dissipates the excess; the report says how much it took
// out.
//
// Units: stylus metres, seconds, newtons; tip nm. Axes: frame A's (the
// joystick's x, y; z up).
#pragma once

#include "scene.hpp"

namespace afm {

// The stylus in the hand, one block at a time.
class HapticLoop {
public:
    HapticLoop(const HapticSpec &device, const HandSpec &hand, double block_s, Vec2 start_m, Vec2 start_m_per_s = {});

    // One block: the hand's aim moves linearly to `aim_m` over the block
    // (the stylus position the operator means), the device renders
    // `force_N` (HAPTIC_FORCE, held over the block); with the z axis, the
    // same for aim_z_m (the press) and force_z_N (g F_z, up).
    void step(Vec2 aim_m, Vec2 force_N, double aim_z_m = 0, double force_z_N = 0);

    Vec2 position_m() const { return x_; }
    Vec2 velocity_m_per_s() const { return v_; }
    double z_m() const { return z_; }                  // 0 without the z axis
    void place_z(double z_m) { z_ = aim_z_ = z_m; vz_ = 0; }   // the stylus held at rest at this depth (the start)
    // The load the stylus asks for (z axis): load_span x depth / half_range, nN.
    double load_nN() const;
    // Energy the stylus has given the device (its damping, the rendered
    // force and the controller), J: never below 0 once the controller acts.
    double observed_energy_J() const { return observed_J_; }
    double controller_energy_J() const { return controller_J_; }   // what the controller dissipated
    long controller_blocks() const { return controller_blocks_; }  // blocks it acted in
    long edge_blocks() const { return edge_blocks_; }              // blocks the stylus hit the workspace edge
    // Switch the controller off (tests: to show what it prevents).
    void set_controller(bool on) { controller_on_ = on; }

private:
    HapticSpec dev_;
    HandSpec hand_;
    double T_;
    Vec2 x_, v_, aim_;
    double z_ = 0, vz_ = 0, aim_z_ = 0;   // the third axis (dev_.load_span_nN > 0)
    double observed_J_ = 0, controller_J_ = 0;
    long controller_blocks_ = 0, edge_blocks_ = 0;
    bool controller_on_ = true;
};

}  // namespace afm
