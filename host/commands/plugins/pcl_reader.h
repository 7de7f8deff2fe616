#pragma once
// C interface of the PCL reader plug-in (libmlp_pcl_reader.so), loaded with dlopen.
#include <stddef.h>

extern "C" {
/// Reads `path` (.pcd or .ply). On success returns 0 and a malloc'd x,y,z array of 3*n doubles
/// (caller frees). On failure returns non-zero and writes a message into err.
typedef int (*MlpReadPclCloudFn)(
    const char* path, double** xyz, size_t* n, char* err, size_t err_len);
int mlp_read_pcl_cloud(const char* path, double** xyz, size_t* n, char* err, size_t err_len);
}
