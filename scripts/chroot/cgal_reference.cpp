// CGAL's 3D barycentric coordinates on a cage and points given by scripts/benchmarks/bench_core.py,
// so the benchmark compares both implementations on one machine, in one run, on the
// same data (and checks that the two agree). Not part of the extension.
//
// Build (CGAL 6.x headers and Boost, e.g. Debian's libcgal-dev; see scripts/chroot/cgal_reference.sh):
//   g++ -O3 -DNDEBUG -std=c++17 scripts/chroot/cgal_reference.cpp -o build/cgal_reference
// Run:
//   cgal_reference KIND CAGE.off POINTS.f64 COUNT REPEATS OUT.f64
// KIND is wachspress, mean_value or discrete_harmonic; POINTS.f64 holds COUNT x 3 doubles;
// OUT.f64 receives COUNT x n coordinates (cage vertex order). Prints the best of REPEATS
// wall times in seconds, one thread, the cage prepared once.

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Barycentric_coordinates_3/Wachspress_coordinates_3.h>
#include <CGAL/Barycentric_coordinates_3/Mean_value_coordinates_3.h>
#include <CGAL/Barycentric_coordinates_3/Discrete_harmonic_coordinates_3.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

using Kernel = CGAL::Simple_cartesian<double>;
using Point_3 = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point_3>;
namespace BC = CGAL::Barycentric_coordinates;

template <typename Coordinates>
double best_seconds(Coordinates& coordinates, const std::vector<Point_3>& points,
                    int repeats, std::vector<double>& out) {
  double best = 1e300;
  for (int repeat = 0; repeat < repeats; ++repeat) {
    out.clear();
    const auto start = std::chrono::steady_clock::now();
    for (const Point_3& point : points) coordinates(point, std::back_inserter(out));
    const std::chrono::duration<double> seconds = std::chrono::steady_clock::now() - start;
    best = std::min(best, seconds.count());
  }
  return best;
}

int main(int argc, char** argv) {
  if (argc != 7) {
    std::cerr << "usage: cgal_reference KIND CAGE.off POINTS.f64 COUNT REPEATS OUT.f64\n";
    return 2;
  }
  const std::string kind = argv[1];
  Mesh cage;
  std::ifstream off(argv[2]);
  if (!(off >> cage)) { std::cerr << "cannot read " << argv[2] << "\n"; return 2; }
  const std::size_t count = std::stoul(argv[4]);
  const int repeats = std::stoi(argv[5]);
  std::vector<double> raw(3 * count);
  std::FILE* file = std::fopen(argv[3], "rb");
  if (!file || std::fread(raw.data(), sizeof(double), raw.size(), file) != raw.size()) {
    std::cerr << "cannot read " << argv[3] << "\n";
    return 2;
  }
  std::fclose(file);
  std::vector<Point_3> points;
  points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) points.emplace_back(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);

  // FAST: no boundary handling, as the points are strictly inside.
  const auto policy = BC::Computation_policy_3::FAST;
  std::vector<double> out;
  out.reserve(count * cage.number_of_vertices());
  double seconds;
  if (kind == "wachspress") {
    BC::Wachspress_coordinates_3<Mesh> coordinates(cage, policy);
    seconds = best_seconds(coordinates, points, repeats, out);
  } else if (kind == "mean_value") {
    BC::Mean_value_coordinates_3<Mesh> coordinates(cage, policy);
    seconds = best_seconds(coordinates, points, repeats, out);
  } else if (kind == "discrete_harmonic") {
    BC::Discrete_harmonic_coordinates_3<Mesh> coordinates(cage, policy);
    seconds = best_seconds(coordinates, points, repeats, out);
  } else {
    std::cerr << "unknown kind " << kind << "\n";
    return 2;
  }
  std::FILE* result = std::fopen(argv[6], "wb");
  std::fwrite(out.data(), sizeof(double), out.size(), result);
  std::fclose(result);
  std::printf("%.9f\n", seconds);
  return 0;
}
