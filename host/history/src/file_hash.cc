#include "mlp/history/file_hash.h"

#include <cstdio>
#include <fstream>

#include <openssl/evp.h>

namespace mlp::history {

namespace {

// One digest over what `feed` hands it, as lower-case hex.
template <class Feed>
std::string Sha256Hex(Feed feed) {
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  feed([ctx](const char* data, size_t n) { EVP_DigestUpdate(ctx, data, n); });
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_DigestFinal_ex(ctx, md, &n);
  EVP_MD_CTX_free(ctx);
  std::string hex;
  char two[3];
  for (unsigned int i = 0; i < n; ++i) {
    std::snprintf(two, sizeof two, "%02x", md[i]);
    hex += two;
  }
  return hex;
}

}  // namespace

std::string Sha256OfFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw HistoryError("cannot read " + path + " to hash it");
  return Sha256Hex([&](const auto& update) {
    char buf[1 << 16];
    while (in.read(buf, sizeof buf) || in.gcount() > 0)
      update(buf, static_cast<size_t>(in.gcount()));
  });
}

std::string Sha256OfText(const std::string& text) {
  return Sha256Hex([&](const auto& update) { update(text.data(), text.size()); });
}

}  // namespace mlp::history
