// base/npy.h — a NumPy .npy file of one structured array (the format of numpy.lib.format, NEP 1:
// magic "\x93NUMPY", version, a header that is a Python dict literal, then the records packed,
// without padding). numpy.load(path, mmap_mode="r") maps it without parsing; any language can read
// it from the header's field list. Used by results/ (points.npy, docs/results.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace vlt::base_internal {

// The fields of a record, in order, and the header that describes them.
class NpyLayout {
 public:
  // Adds a field of doubles (native byte order, "<f8" on little-endian machines): a scalar
  // (shape {}), a vector {3} or a matrix {3, 3} (C order: row after row).
  void AddDoubles(std::string name, std::vector<int> shape = {});
  // A signed byte ("|i1"), a boolean ("|b1"), a byte string of `width` bytes ("|S<width>",
  // NUL-padded: numpy strips the padding).
  void AddByte(std::string name);
  void AddBool(std::string name);
  void AddBytes(std::string name, int width);

  std::size_t record_size() const { return record_size_; }
  // Magic, version and header for `records` records: version 1.0 when the header fits 65535 bytes
  // and is ASCII, 2.0 when longer, 3.0 when a field name is not ASCII (its UTF-8 kept).
  std::string Header(std::size_t records) const;

 private:
  struct Field {
    std::string name;
    std::string type;
    std::vector<int> shape;
  };
  void Add(std::string name, std::string type, std::vector<int> shape, std::size_t bytes);
  std::vector<Field> fields_;
  std::size_t record_size_ = 0;
};

// Appends one record's fields to a byte string, in the layout's order.
class NpyRecordWriter {
 public:
  explicit NpyRecordWriter(std::string& out) : out_(out) {}
  NpyRecordWriter& Double(double v);
  NpyRecordWriter& Vector(const Eigen::Vector3d& v);
  NpyRecordWriter& Matrix(const Eigen::Matrix3d& m);  // row after row
  NpyRecordWriter& Byte(std::int8_t v);
  NpyRecordWriter& Bool(bool v);
  NpyRecordWriter& Bytes(std::string_view text, int width);  // cut at width, NUL-padded

 private:
  std::string& out_;
};

// The field name as a Python string literal ('...' with \\, \' and control bytes escaped).
std::string PythonStringLiteral(std::string_view text);

}  // namespace vlt::base_internal
