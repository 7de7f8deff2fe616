// PCL-backed reader for .pcd (ascii, binary, binary_compressed) and .ply files. Lives in its own
// shared library so that only programs reading such files load PCL and VTK.

#include "pcl_reader.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

namespace {

bool EndsWith(const std::string& s, const char* suffix) {
  const size_t n = std::strlen(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

}  // namespace

extern "C" int mlp_read_pcl_cloud(
    const char* path, double** xyz, size_t* n, char* err, size_t err_len) {
  pcl::PCLPointCloud2 blob;
  const std::string p(path);
  int rc = -1;
  // PCL prints its own complaints on stderr; the caller reports one clear line instead.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  if (EndsWith(p, ".pcd")) {
    rc = pcl::io::loadPCDFile(p, blob);
  } else if (EndsWith(p, ".ply")) {
    rc = pcl::io::loadPLYFile(p, blob);
  }
  if (rc < 0) {
    std::snprintf(err, err_len, "cannot read %s as a point cloud", path);
    return 1;
  }
  bool has_xyz[3] = {false, false, false};
  for (const auto& f : blob.fields) {
    if (f.name == "x") has_xyz[0] = true;
    if (f.name == "y") has_xyz[1] = true;
    if (f.name == "z") has_xyz[2] = true;
  }
  if (!has_xyz[0] || !has_xyz[1] || !has_xyz[2]) {
    std::snprintf(err, err_len, "%s has no x, y, z fields", path);
    return 1;
  }
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2(blob, cloud);
  *n = cloud.size();
  *xyz = static_cast<double*>(std::malloc(3 * (*n > 0 ? *n : 1) * sizeof(double)));
  if (*xyz == nullptr) {
    std::snprintf(err, err_len, "out of memory reading %s", path);
    return 1;
  }
  for (size_t i = 0; i < *n; ++i) {
    (*xyz)[3 * i] = cloud[i].x;
    (*xyz)[3 * i + 1] = cloud[i].y;
    (*xyz)[3 * i + 2] = cloud[i].z;
  }
  return 0;
}
