// base/sha256.cc — SHA-256 of files and bytes (vlt/calibration.h; OpenSSL's EVP): the provenance of
// every input file in results.json, the reports and the calibration file.
#include <fstream>
#include <string>
#include <string_view>

#include <openssl/evp.h>

#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/input_file.h"

namespace vlt {

namespace {

// SHA-256 of what `feed` passes to its argument (called repeatedly with chunks), lower-case hex.
template <typename Feed>
std::string Sha256Hex(Feed&& feed) {
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  if (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) != 1) {
    EVP_MD_CTX_free(ctx);
    throw NumericalError("SHA-256 is not available (OpenSSL)");
  }
  feed([&](const char* data, std::size_t size) { EVP_DigestUpdate(ctx, data, size); });
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_DigestFinal_ex(ctx, digest, &length);
  EVP_MD_CTX_free(ctx);
  std::string hex;
  static const char* kHex = "0123456789abcdef";
  for (unsigned int i = 0; i < length; ++i) {
    hex += kHex[digest[i] >> 4];
    hex += kHex[digest[i] & 15];
  }
  return hex;
}

}  // namespace

std::string Sha256File(const std::string& path) {
  const std::string bytes = ReadInputFile(path, path, "cannot read the file to hash it");
  return Sha256Bytes(bytes);
}

std::string Sha256Bytes(std::string_view bytes) {
  return Sha256Hex([&](auto&& update) { update(bytes.data(), bytes.size()); });
}

}  // namespace vlt
