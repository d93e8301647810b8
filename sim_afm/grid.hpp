// A uniform grid over the sample plane: which particles lie near a point.
// Per query, the cost depends on the particles near the point, not on all.
#pragma once

#include <Eigen/Dense>

#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace afm::sim {

class Grid {
public:
    // cell_nm: cell side; choose at least the largest contact reach so that a
    // query of radius <= cell_nm visits 3 x 3 cells.
    explicit Grid(double cell_nm) : cell_(cell_nm > 0 ? cell_nm : 1.0) {}

    void insert(int idx, const Eigen::Vector2d &p)
    {
        if (static_cast<std::size_t>(idx) >= key_of_.size()) key_of_.resize(idx + 1, kNone);
        const int64_t k = key(p);
        key_of_[idx] = k;
        cells_[k].push_back(idx);
        ++occupied_[slot(k)];
    }

    // Call after a point moved; cheap when it stays in its cell.
    void update(int idx, const Eigen::Vector2d &p)
    {
        const int64_t k = key(p);
        const int64_t old = key_of_[idx];
        if (k == old) return;
        auto &v = cells_[old];
        for (std::size_t i = 0; i < v.size(); ++i)
            if (v[i] == idx) { v[i] = v.back(); v.pop_back(); break; }
        --occupied_[slot(old)];
        key_of_[idx] = k;
        cells_[k].push_back(idx);
        ++occupied_[slot(k)];
    }

    // Appends to `out` every index whose cell touches the square of half side
    // `radius` around p (a superset of those within `radius`).
    void query(const Eigen::Vector2d &p, double radius, std::vector<int> &out) const
    {
        const int64_t x0 = cell_index(p.x() - radius), x1 = cell_index(p.x() + radius);
        const int64_t y0 = cell_index(p.y() - radius), y1 = cell_index(p.y() + radius);
        for (int64_t cx = x0; cx <= x1; ++cx)
            for (int64_t cy = y0; cy <= y1; ++cy) {
                const int64_t k = pack(cx, cy);
                if (occupied_[slot(k)] == 0) continue;   // no point in that cell (nor in any sharing its slot)
                auto it = cells_.find(k);
                if (it != cells_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
            }
    }

private:
    static constexpr int64_t kNone = INT64_MIN;
    int64_t cell_index(double v) const { return static_cast<int64_t>(std::floor(v / cell_)); }
    static int64_t pack(int64_t cx, int64_t cy) { return (cx << 32) ^ (cy & 0xffffffffLL); }
    int64_t key(const Eigen::Vector2d &p) const { return pack(cell_index(p.x()), cell_index(p.y())); }
    // A cell's slot in occupied_: a multiplicative hash of its key.
    static std::size_t slot(int64_t k) { return static_cast<std::size_t>((static_cast<uint64_t>(k) * 0x9E3779B97F4A7C15ull) >> (64 - kSlotBits)); }
    static constexpr int kSlotBits = 12;

    double cell_;
    std::unordered_map<int64_t, std::vector<int>> cells_;
    std::vector<int64_t> key_of_;
    // Points per slot (cells hashed into 4096 slots): a query skips the
    // hash map's lookup for a cell whose slot holds no point, which on a
    // scan of a sparse sample is nearly every cell.
    std::vector<uint32_t> occupied_ = std::vector<uint32_t>(std::size_t{1} << kSlotBits, 0);
};

}  // namespace afm::sim
