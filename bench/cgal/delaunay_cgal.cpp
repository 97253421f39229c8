// CGAL's 3D Delaunay on the exact points of a portalfind benchmark case, for a comparison
// on the same machine, at the same time, on identical input (see README.md beside this file).
//
// Input: raw little-endian f64 triples (`portalfind bench points KIND N FILE`).
// Output: one line of JSON: construction seconds (best and median of the runs), finite
// cells, peak RSS; `is_valid()` is checked once, untimed. Construction = `Delaunay_triangulation_3<Epick>(begin, end)`, which
// spatially sorts (BRIO + Hilbert) and inserts; reading the file is not timed.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Delaunay_triangulation_3.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using DT = CGAL::Delaunay_triangulation_3<K>;
using Point = K::Point_3;

static double peak_rss_mb() {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line)) {
        if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    }
    return -1.0;
}

int main(int argc, char** argv) {
    if (argc < 2) {
        std::cerr << "usage: delaunay_cgal POINTS.f64 [RUNS]\n";
        return 2;
    }
    int runs = argc > 2 ? std::atoi(argv[2]) : 1;
    std::ifstream in(argv[1], std::ios::binary);
    if (!in) {
        std::cerr << "cannot read " << argv[1] << "\n";
        return 1;
    }
    in.seekg(0, std::ios::end);
    std::size_t bytes = static_cast<std::size_t>(in.tellg());
    in.seekg(0);
    std::vector<double> xyz(bytes / sizeof(double));
    in.read(reinterpret_cast<char*>(xyz.data()), static_cast<std::streamsize>(xyz.size() * sizeof(double)));
    std::vector<Point> pts;
    pts.reserve(xyz.size() / 3);
    for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) pts.emplace_back(xyz[i], xyz[i + 1], xyz[i + 2]);
    xyz.clear();
    xyz.shrink_to_fit();
    std::vector<double> times;
    std::size_t cells = 0;
    for (int r = 0; r < runs; ++r) {
        auto t0 = std::chrono::steady_clock::now();
        DT dt(pts.begin(), pts.end());
        auto t1 = std::chrono::steady_clock::now();
        times.push_back(std::chrono::duration<double>(t1 - t0).count());
        cells = dt.number_of_finite_cells();
        if (r == 0 && !dt.is_valid()) {
            std::cerr << "CGAL's is_valid() failed\n";
            return 1;
        }
    }
    std::sort(times.begin(), times.end());
    double median = times.size() % 2 ? times[times.size() / 2]
                                     : 0.5 * (times[times.size() / 2 - 1] + times[times.size() / 2]);
    std::printf("{\"points\": %zu, \"best\": %.3f, \"median\": %.3f, \"runs\": %d, \"finite_cells\": %zu, \"peak_rss_mb\": %.0f}\n",
                pts.size(), times.front(), median, runs, cells, peak_rss_mb());
    return 0;
}
