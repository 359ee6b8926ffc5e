// base/npy.cc — the .npy header and records (numpy.lib.format, NEP 1).
#include "base/npy.h"

#include <bit>
#include <cstdio>
#include <cstring>

namespace vlt::base_internal {
namespace {

// The byte-order character of a multi-byte field: the records are written in the machine's order
// and the header says which.
constexpr char kNativeOrder = std::endian::native == std::endian::little ? '<' : '>';

std::string ShapeLiteral(const std::vector<int>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

void AppendLittle(std::string& out, std::uint32_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
}

}  // namespace

std::string PythonStringLiteral(std::string_view text) {
  std::string s = "'";
  for (const char c : text) {
    const auto b = static_cast<unsigned char>(c);
    if (c == '\\' || c == '\'') {
      s += '\\';
      s += c;
    } else if (b < 0x20 || b == 0x7F) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", b);
      s += escaped;
    } else {
      s += c;  // printable ASCII, or UTF-8 (version 3.0 headers are UTF-8)
    }
  }
  return s + "'";
}

void NpyLayout::Add(std::string name, std::string type, std::vector<int> shape, std::size_t bytes) {
  std::size_t count = 1;
  for (const int n : shape) count *= static_cast<std::size_t>(n);
  record_size_ += bytes * count;
  fields_.push_back({std::move(name), std::move(type), std::move(shape)});
}

void NpyLayout::AddDoubles(std::string name, std::vector<int> shape) {
  Add(std::move(name), std::string(1, kNativeOrder) + "f8", std::move(shape), 8);
}
void NpyLayout::AddByte(std::string name) { Add(std::move(name), "|i1", {}, 1); }
void NpyLayout::AddBool(std::string name) { Add(std::move(name), "|b1", {}, 1); }
void NpyLayout::AddBytes(std::string name, int width) {
  Add(std::move(name), "|S" + std::to_string(width), {}, static_cast<std::size_t>(width));
}

std::string NpyLayout::Header(std::size_t records) const {
  std::string descr = "[";
  bool ascii = true;
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    const Field& f = fields_[i];
    for (const char c : f.name) ascii = ascii && static_cast<unsigned char>(c) < 0x80;
    descr += (i ? ", (" : "(") + PythonStringLiteral(f.name) + ", '" + f.type + "'";
    if (!f.shape.empty()) descr += ", " + ShapeLiteral(f.shape);
    descr += ")";
  }
  descr += "]";
  std::string dict =
      "{'descr': " + descr + ", 'fortran_order': False, 'shape': (" + std::to_string(records) + ",), }";
  // The header (dict, spaces, '\n') ends where the whole preamble is a multiple of 64 bytes, so
  // that the records are aligned (numpy.lib.format ARRAY_ALIGN).
  int major = ascii ? 1 : 3;
  std::size_t preamble = 10;  // magic 6, version 2, length 2 (version 1.0)
  if (major == 1 && dict.size() + 1 + 10 + 64 > 65535) major = 2;
  if (major != 1) preamble = 12;  // length 4
  const std::size_t unpadded = preamble + dict.size() + 1;
  const std::size_t padded = (unpadded + 63) / 64 * 64;
  dict.append(padded - unpadded, ' ');
  dict += '\n';
  std::string out = "\x93NUMPY";
  out += static_cast<char>(major);
  out += '\0';
  AppendLittle(out, static_cast<std::uint32_t>(dict.size()), major == 1 ? 2 : 4);
  return out + dict;
}

NpyRecordWriter& NpyRecordWriter::Double(double v) {
  char bytes[sizeof v];
  std::memcpy(bytes, &v, sizeof v);
  out_.append(bytes, sizeof v);
  return *this;
}

NpyRecordWriter& NpyRecordWriter::Vector(const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) Double(v(i));
  return *this;
}

NpyRecordWriter& NpyRecordWriter::Matrix(const Eigen::Matrix3d& m) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) Double(m(i, j));
  }
  return *this;
}

NpyRecordWriter& NpyRecordWriter::Byte(std::int8_t v) {
  out_ += static_cast<char>(v);
  return *this;
}

NpyRecordWriter& NpyRecordWriter::Bool(bool v) { return Byte(v ? 1 : 0); }

NpyRecordWriter& NpyRecordWriter::Bytes(std::string_view text, int width) {
  const std::size_t n = std::min(text.size(), static_cast<std::size_t>(width));
  out_.append(text.data(), n);
  out_.append(static_cast<std::size_t>(width) - n, '\0');
  return *this;
}

}  // namespace vlt::base_internal
