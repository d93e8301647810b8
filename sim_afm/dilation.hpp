// The image a tip makes of a height map (physics.md section 11): its
// morphological dilation by the tip's shape, over a lattice of the field.
// A library of the simulator; World's scans use it (world_imaging.cpp).
//
// The tip (TipShape): a cone of half angle gamma whose spherical apex of
// radius R is tangent to it (tip_geometry.hpp's tip, on its axis, upright);
// its surface stands t(u) above the apex at horizontal distance u. R >= 0
// (0: a sharp cone), gamma in (0, pi/2). The closed forms (TipShape::bump,
// TipShape::pillar) answer a sphere or cylinder, or a square pillar, alone
// on a flat: the tests' oracle for the lattice.
//
// The height map (DilatedField), sampled at the nodes (x0 + i h, y0 + j h)
// of a square lattice in frame A, nm, by a caller's fill (one row of nodes
// at a time): the substrate B (with roughness or a measured map), the
// grooves' depth G >= 0 (lithography), the objects' surface O (particles,
// wires, landmarks on the substrate; -infinity where there is none). The
// image at node p is
//
//     I(p) = max over the lattice's offsets u of  max(B(p + u) - G(p), O(p + u)) - t(|u|)
//
// that is max(D[B](p) - G(p), D[O](p)) with D the dilation: objects and the
// substrate dilated by the tip, a groove carved from the dilated substrate
// as deep as it was cut. A groove is the trace of the tip that cut it, so
// the tip fits it (its walls are the cone's flank) and it is imaged at its
// depth, unfilled, as a dilation of the tip's own trace is; the world's
// sharp V (the cone without its apex) would otherwise be lifted by the
// apex, R (1 / sin gamma - 1), 19 nm for 10 nm at 20 deg, across its width.
//
// Cost: per node, the offsets in order of t (the footprint, out to where t
// exceeds the map's relief, DilatedField's relief_nm) until t reaches the
// most the map rises in the node's neighbourhood (the greatest B and O over
// the 8 x 8 blocks within the footprint) above the best found: a few
// offsets on a smooth substrate, the footprint near a tall object. The
// lattice is built lazily in tiles of kTile x kTile nodes, the map's with a
// margin of the footprint, as queries reach them; past kKeepTiles, the
// tiles well below the one asked for are dropped.
//
// Error against the continuous dilation (tests/sim/test_dilation.cpp): the
// maximum is taken over lattice offsets, so a node's image lies below the
// continuous one by at most what the gap's curvature gives over half a
// diagonal; between nodes the image is bilinear. Stated bound: within 0.3
// of a lattice step's height on the cone's flank, cot(gamma) h, for a
// sphere or a cylinder at least 2 h in radius alone on a flat (measured:
// 0.26 at most; 0.17 for the paper's tip over a 50 nm sphere).
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <memory>
#include <unordered_map>
#include <vector>

namespace afm::sim {

struct TipShape {
    double radius_nm = 0;        // R, the apex's radius, >= 0
    double half_angle_rad = 0;   // gamma, (0, pi/2)

    // t(u): the tip's surface above its apex at horizontal distance u >= 0, nm.
    double profile(double u) const;
    // The horizontal distance at which t reaches height z >= 0 (t's inverse), nm.
    double reach(double z) const;
    // The apex's height over a sphere (or a cylinder, across its axis) of
    // radius r resting on a flat at 0, at horizontal distance rho from its
    // centre (axis): the closed form of the dilation, by a golden-section
    // search on the concave gap along the plane through the tip's axis and
    // the centre, to 1e-6 nm; 0 where the tip clears it.
    double bump(double rho, double r) const;
    // The apex's height beside a flat-topped pillar of height H at
    // horizontal distance d >= 0 from its top's edge: H - t(d), or H on it.
    double pillar(double d, double height_nm) const;
};

// One row of the map: n nodes from (x, y) in steps of h along +x; writes
// base[i], groove[i] (>= 0) and object[i] (-infinity where none).
using MapFill = std::function<void(double x, double y, int n, double h, double *base, double *groove, double *object)>;

class DilatedField {
public:
    static constexpr int kTile = 32;    // nodes a tile's side
    static constexpr int kBlock = 8;    // nodes a bound block's side (kTile / kBlock blocks a tile's side)
    static constexpr int kMaxReach = 128;   // the footprint's radius at most, steps
    // Tiles kept at most before those a row of tiles or more below the one
    // asked for are dropped (a scan goes up its rows; 4096 tiles of the map
    // are about 100 MB): a tile asked for again is computed again.
    static constexpr std::size_t kKeepTiles = 4096;

    // The lattice (x0, y0, h > 0), the tip, the map's relief (the most any
    // point of the map may rise above another within the footprint: objects,
    // roughness, a measured map's span, >= 0) and slope (the most its
    // substrate rises per nm, >= 0; at cot gamma or more the footprint is
    // the largest, kMaxReach steps), and the fill. Throws
    // std::invalid_argument (one line, the pitch) out of those ranges.
    DilatedField(const TipShape &tip, double x0_nm, double y0_nm, double h_nm, double relief_nm, double slope, MapFill fill);

    // The image at (x, y) (frame A, nm), bilinear between the four nodes
    // around it, and its gradient (each node's by central differences,
    // bilinear likewise) when grad is not null.
    double height(double x, double y, Eigen::Vector2d *grad = nullptr) const;
    // The image at node (i, j).
    double node(int64_t i, int64_t j) const;

    double x0() const { return x0_; }
    double y0() const { return y0_; }
    double pitch() const { return h_; }
    int footprint_nodes() const { return reach_; }   // the footprint's radius, nodes
    std::size_t tiles() const { return images_.size(); }

private:
    struct Map {      // the map on one tile, kTile rows of kTile, row j at y0 + j h
        std::vector<double> b, g, o;
        std::vector<double> max_b, max_o;   // per kBlock x kBlock block
    };
    struct Offset { int di, dj; double t; };
    static int64_t key(int64_t ti, int64_t tj) { return (ti << 32) ^ (tj & 0xffffffffLL); }
    const Map &map(int64_t ti, int64_t tj) const;
    const std::vector<double> &image(int64_t ti, int64_t tj) const;
    void dilate_tile(int64_t ti, int64_t tj, std::vector<double> &out) const;
    // The map at node (i, j) (any tile), and the greatest B and O over the
    // blocks within the footprint of the block holding (i, j).
    void map_at(int64_t i, int64_t j, double *b, double *o) const;
    void bound(int64_t bi, int64_t bj, double *mb, double *mo) const;
    void drop_below(int64_t tj) const;   // the tiles of rows below tj

    TipShape tip_;
    double x0_, y0_, h_;
    int reach_;                      // footprint radius, nodes
    std::vector<Offset> offsets_;    // the footprint, t ascending (0 first)
    MapFill fill_;
    mutable std::unordered_map<int64_t, Map> maps_;
    mutable std::unordered_map<int64_t, std::vector<double>> images_;
    mutable const Map *last_map_ = nullptr;
    mutable int64_t last_map_key_ = 0;
};

}  // namespace afm::sim
