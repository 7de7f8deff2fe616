// Writes the sample clouds of samples/clouds/ (deterministic; ground truth in the README there).
// Run once by hand (build/bin/mlp_make_sample_clouds samples/clouds); the outputs are committed.

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace {

struct P3 {
  double x, y, z;
};

void Write(const std::string& path,
           const std::vector<P3>& pts,
           const std::vector<std::string>& header) {
  FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    std::perror(path.c_str());
    std::exit(1);
  }
  for (const auto& h : header) std::fprintf(f, "# %s\n", h.c_str());
  for (const auto& p : pts) std::fprintf(f, "%.5f %.5f %.5f\n", p.x, p.y, p.z);
  std::fclose(f);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : "samples/clouds";
  std::mt19937_64 rng(20261121);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double deg = M_PI / 180.0;

  // Reference ball d = 25.4 mm seen from above: 120 deg cap, 3 um noise, 2 % specks outside.
  std::vector<P3> ball;
  for (int i = 0; i < 3000; ++i) {
    const double polar = std::acos(1 - uni(rng) * (1 - std::cos(60 * deg)));
    const double az = 2 * M_PI * uni(rng);
    double r = 12.7 + 0.003 * gauss(rng);
    if (uni(rng) < 0.02) r += 0.2 + 1.8 * uni(rng);
    ball.push_back({250 + r * std::sin(polar) * std::cos(az),
                    -120 + r * std::sin(polar) * std::sin(az), -310 + r * std::cos(polar)});
  }
  Write(dir + "/reference_ball_cap.xyz", ball,
        {"reference ball d = 25.4 mm, centre (250, -120, -310) mm",
         "120 deg cap, 3 um noise, 2 % specks 0.2-2 mm outside"});

  // Seed 004 example: bore to be finished to d = 60, measured at d = 59.94 before the last pass.
  std::vector<P3> bore;
  for (int ring = 0; ring < 6; ++ring) {
    const double z = -2.0 - 2.0 * ring;
    for (int k = 0; k < 240; ++k) {
      const double t = 2 * M_PI * k / 240;
      const double r = 29.97 + 0.004 * std::cos(3 * t + 0.4) + 0.002 * gauss(rng);
      bore.push_back({40 + r * std::cos(t), 25 + r * std::sin(t), z});
    }
  }
  Write(dir + "/bore_before_finish.xyz", bore,
        {"bore, nominal d = 60 mm, actual d = 59.94 mm before the finishing pass",
         "axis along z through (40, 25), z = -2..-12; 3-lobe form 4 um peak; 2 um noise"});

  // Machined face 80 x 60 mm, tilted 0.01 deg about x, 3 um crown along x, 1 um noise.
  std::vector<P3> face;
  for (int i = 0; i < 2500; ++i) {
    const double x = 80 * uni(rng), y = 60 * uni(rng);
    const double crown = 0.003 * (1 - ((x - 40) / 40) * ((x - 40) / 40));
    face.push_back({x, y, std::tan(0.01 * deg) * (y - 30) + crown + 0.001 * gauss(rng)});
  }
  Write(dir + "/top_face.xyz", face,
        {"machined face 80 x 60 mm at z = 0, tilted 0.01 deg about x, 3 um crown, 1 um noise"});
  return 0;
}
