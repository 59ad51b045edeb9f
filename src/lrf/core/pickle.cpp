#include "lrf/core/pickle.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include <torch/torch.h>

#include "lrf/core/byte_source.h"
#include "lrf/core/error.h"

namespace lrf::pickle {
namespace {

// Bounds for hostile inputs: a real state dict's data.pkl is at most a few MB with ~10^4 objects.
constexpr std::size_t kMaxPickleBytes = 512u << 20;
constexpr std::size_t kMaxObjects = 50'000'000;
constexpr std::size_t kMaxDims = 16;
// Nesting bound: a state dict nests 3-4 levels; unbounded nesting would overflow the stack when the
// value tree is destroyed.
constexpr int kMaxDepth = 100;
// Element bounds of a tensor view: any view, and one with more elements than its storage holds.
constexpr std::int64_t kMaxViewElements = std::int64_t{1} << 48;
constexpr std::int64_t kMaxExpandedElements = std::int64_t{1} << 24;

struct StorageType {
  const char* name;
  at::ScalarType type;
  std::size_t bytes;
};
const StorageType kStorages[] = {
    {"torch.FloatStorage", at::kFloat, 4}, {"torch.HalfStorage", at::kHalf, 2},
    {"torch.BFloat16Storage", at::kBFloat16, 2}, {"torch.LongStorage", at::kLong, 8},
    {"torch.DoubleStorage", at::kDouble, 8}, {"torch.IntStorage", at::kInt, 4},
    {"torch.ByteStorage", at::kByte, 1}, {"torch.BoolStorage", at::kBool, 1},
};

const char* const kCallables[] = {"collections.OrderedDict", "torch._utils._rebuild_tensor_v2",
                                  "torch._utils._rebuild_parameter"};

bool allowed_global(const std::string& g) {
  for (const char* c : kCallables)
    if (g == c) return true;
  at::ScalarType t;
  std::size_t b;
  return storage_dtype(g, &t, &b);
}

Ref make(Value::Kind kind) {
  auto v = std::make_shared<Value>();
  v->kind = kind;
  return v;
}

class Unpickler {
 public:
  Unpickler(const std::string& bytes, const std::string& name, const PersistentLoader& load)
      : data_(reinterpret_cast<const unsigned char*>(bytes.data())), size_(bytes.size()), name_(name), load_(load) {
    if (size_ > kMaxPickleBytes) bad("pickle of " + std::to_string(size_) + " bytes is too large");
  }

  Ref run() {
    while (true) {
      std::size_t at = pos_;
      unsigned char op = u8();
      switch (op) {
        case 0x80: {  // PROTO
          unsigned proto = u8();
          if (proto > 5) bad("unsupported pickle protocol " + std::to_string(proto));
          break;
        }
        case 0x95: take(8); break;  // FRAME: a length hint, no content
        case '.': {                 // STOP
          if (stack_.size() != 1 || !marks_.empty()) bad("malformed pickle: stack not balanced at STOP");
          return stack_.back();
        }
        case '(': marks_.push_back(stack_.size()); break;  // MARK
        case '0': pop(); break;                             // POP
        case '1': pop_mark(); break;                        // POP_MARK
        case '2': push(top()); break;                       // DUP
        case 'N': push(make(Value::Kind::none)); break;
        case 0x88: case 0x89: {  // NEWTRUE / NEWFALSE
          auto v = make(Value::Kind::boolean);
          v->boolean = op == 0x88;
          push(v);
          break;
        }
        case 'K': push_int(u8()); break;                                       // BININT1
        case 'M': push_int(load_le16(take(2))); break;                         // BININT2
        case 'J': push_int(static_cast<std::int32_t>(load_le32(take(4)))); break;  // BININT
        case 0x8a: {  // LONG1
          std::size_t n = u8();
          if (n > 8) bad("integer wider than 64 bits");
          const unsigned char* p = take(n);
          std::uint64_t v = 0;
          for (std::size_t i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
          if (n > 0 && n < 8 && (p[n - 1] & 0x80)) v |= ~std::uint64_t{0} << (8 * n);  // sign-extend
          push_int(static_cast<std::int64_t>(v));
          break;
        }
        case 'G': {  // BINFLOAT (big-endian double)
          const unsigned char* p = take(8);
          std::uint64_t bits = 0;
          for (int i = 0; i < 8; ++i) bits = (bits << 8) | p[i];
          auto v = make(Value::Kind::floating);
          std::memcpy(&v->floating, &bits, 8);
          push(v);
          break;
        }
        case 'X': push_text(Value::Kind::string, load_le32(take(4))); break;  // BINUNICODE
        case 0x8c: push_text(Value::Kind::string, u8()); break;               // SHORT_BINUNICODE
        case 0x8d: push_text(Value::Kind::string, load_le64(take(8))); break;  // BINUNICODE8
        case 'T': push_text(Value::Kind::string, load_le32(take(4))); break;  // BINSTRING
        case 'U': push_text(Value::Kind::string, u8()); break;                // SHORT_BINSTRING
        case 'B': push_text(Value::Kind::bytes, load_le32(take(4))); break;   // BINBYTES
        case 'C': push_text(Value::Kind::bytes, u8()); break;                 // SHORT_BINBYTES
        case ')': push(make(Value::Kind::tuple)); break;                      // EMPTY_TUPLE
        case 't': {                                                           // TUPLE
          auto v = make(Value::Kind::tuple);
          v->items = pop_mark();
          nest(*v, v->items);
          push(v);
          break;
        }
        case 0x85: case 0x86: case 0x87: {  // TUPLE1..3
          std::size_t n = op - 0x84u;
          if (stack_.size() < n + floor()) bad("stack underflow in TUPLE" + std::to_string(n));
          auto v = make(Value::Kind::tuple);
          v->items.assign(stack_.end() - static_cast<std::ptrdiff_t>(n), stack_.end());
          stack_.resize(stack_.size() - n);
          nest(*v, v->items);
          push(v);
          break;
        }
        case ']': push(make(Value::Kind::list)); break;  // EMPTY_LIST
        case 'l': {                                      // LIST
          auto v = make(Value::Kind::list);
          v->items = pop_mark();
          nest(*v, v->items);
          push(v);
          break;
        }
        case 'a': {  // APPEND
          Ref item = pop();
          Ref list = mutable_container(top(), Value::Kind::list, "APPEND");
          nest(*list, {item});
          list->items.push_back(item);
          break;
        }
        case 'e': {  // APPENDS
          auto items = pop_mark();
          Ref list = mutable_container(top(), Value::Kind::list, "APPENDS");
          nest(*list, items);
          list->items.insert(list->items.end(), items.begin(), items.end());
          break;
        }
        case '}': push(make(Value::Kind::dict)); break;  // EMPTY_DICT
        case 'd': {                                      // DICT
          auto v = make(Value::Kind::dict);
          set_items(*v, pop_mark());
          push(v);
          break;
        }
        case 's': {  // SETITEM
          Ref value = pop();
          Ref key = pop();
          set_items(*mutable_container(top(), Value::Kind::dict, "SETITEM"), {key, value});
          break;
        }
        case 'u': {  // SETITEMS
          auto items = pop_mark();
          set_items(*mutable_container(top(), Value::Kind::dict, "SETITEMS"), items);
          break;
        }
        case 'q': memo_put(u8()); break;                 // BINPUT
        case 'r': memo_put(load_le32(take(4))); break;   // LONG_BINPUT
        case 0x94: memo_put(memo_.size()); break;        // MEMOIZE
        case 'h': push(memo_get(u8())); break;           // BINGET
        case 'j': push(memo_get(load_le32(take(4)))); break;  // LONG_BINGET
        case 'c': {                                      // GLOBAL "module\nname\n"
          std::string module = line(), attr = line();
          push_global(module + "." + attr);
          break;
        }
        case 0x93: {  // STACK_GLOBAL
          Ref attr = pop(), module = pop();
          if (attr->kind != Value::Kind::string || module->kind != Value::Kind::string)
            bad("STACK_GLOBAL needs two strings");
          push_global(module->text + "." + attr->text);
          break;
        }
        case 'R': {  // REDUCE
          Ref args = pop();
          Ref callable = pop();
          push(call(callable, args));
          break;
        }
        case 0x81: {  // NEWOBJ: cls.__new__(cls, *args); only OrderedDict is constructible
          Ref args = pop();
          Ref cls = pop();
          push(call(cls, args));
          break;
        }
        case 'b': {  // BUILD: set attributes. OrderedDict state dicts carry _metadata: dropped.
          Ref state = pop();
          Ref target = top();
          if (target->kind != Value::Kind::dict && target->kind != Value::Kind::tensor)
            bad("BUILD on an unsupported object");
          break;
        }
        case 'Q': {  // BINPERSID
          Ref pid = pop();
          if (!load_) bad("persistent id without a loader");
          push(load_(*pid));
          break;
        }
        default: {
          char hex[8];
          std::snprintf(hex, sizeof hex, "0x%02x", op);
          bad("unknown or unsupported pickle opcode " + std::string(hex) + " at byte " + std::to_string(at));
        }
      }
    }
  }

 private:
  [[noreturn]] void bad(const std::string& what) const { fail(name_, what); }

  const unsigned char* take(std::size_t n) {
    if (n > size_ - pos_) bad("truncated pickle (needs " + std::to_string(n) + " bytes at " + std::to_string(pos_) + ")");
    const unsigned char* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  unsigned u8() { return *take(1); }
  std::string line() {
    std::size_t start = pos_;
    while (pos_ < size_ && data_[pos_] != '\n') ++pos_;
    if (pos_ >= size_) bad("truncated pickle in GLOBAL");
    std::string s(reinterpret_cast<const char*>(data_ + start), pos_ - start);
    ++pos_;
    return s;
  }

  void push(Ref v) {
    if (++objects_ > kMaxObjects) bad("pickle holds too many objects");
    stack_.push_back(std::move(v));
  }
  std::size_t floor() const { return marks_.empty() ? 0 : marks_.back(); }
  Ref pop() {
    if (stack_.size() <= floor()) bad("malformed pickle: stack underflow");
    Ref v = stack_.back();
    stack_.pop_back();
    return v;
  }
  Ref top() {
    if (stack_.size() <= floor()) bad("malformed pickle: stack underflow");
    return stack_.back();
  }
  std::vector<Ref> pop_mark() {
    if (marks_.empty()) bad("malformed pickle: no MARK");
    std::size_t m = marks_.back();
    marks_.pop_back();
    std::vector<Ref> items(stack_.begin() + static_cast<std::ptrdiff_t>(m), stack_.end());
    stack_.resize(m);
    return items;
  }
  Ref expect(const Ref& v, Value::Kind kind, const char* op) {
    if (v->kind != kind) bad(std::string("malformed pickle: ") + op + " on the wrong type");
    return v;
  }
  void push_int(std::int64_t i) {
    auto v = make(Value::Kind::integer);
    v->integer = i;
    push(v);
  }
  void push_text(Value::Kind kind, std::uint64_t n) {
    if (n > size_ - pos_) bad("truncated pickle: string of " + std::to_string(n) + " bytes");
    auto v = make(kind);
    v->text.assign(reinterpret_cast<const char*>(take(static_cast<std::size_t>(n))), static_cast<std::size_t>(n));
    push(v);
  }
  // A list or dict that items are added to. One that already sits inside another container is refused:
  // the pickler fills a container before placing it, so only recursive structures (never in a state
  // dict) do this, and refusing them keeps the value tree acyclic (no leak) and its depth exact.
  Ref mutable_container(const Ref& v, Value::Kind kind, const char* op) {
    expect(v, kind, op);
    if (contained_.count(v.get()))
      bad(std::string("malformed pickle: ") + op + " on a container already placed in another (recursive objects are not supported)");
    return v;
  }
  // Records that `children` go into `container`, refusing excessive nesting and self-containment.
  void nest(Value& container, const std::vector<Ref>& children) {
    for (const auto& c : children) {
      if (c.get() == &container) bad("malformed pickle: a container holds itself");
      container.depth = std::max(container.depth, c->depth + 1);
      if (container.depth > kMaxDepth) bad("pickle nests containers deeper than " + std::to_string(kMaxDepth));
    }
    for (const auto& c : children) contained_.insert(c.get());
  }
  void set_items(Value& dict, const std::vector<Ref>& kv) {
    if (kv.size() % 2) bad("malformed pickle: odd number of dict items");
    nest(dict, kv);
    for (std::size_t i = 0; i < kv.size(); i += 2) dict.entries.emplace_back(kv[i], kv[i + 1]);
  }
  void memo_put(std::uint64_t index) {
    if (memo_.size() > kMaxObjects) bad("pickle memo too large");
    memo_[index] = top();
  }
  Ref memo_get(std::uint64_t index) {
    auto it = memo_.find(index);
    if (it == memo_.end()) bad("malformed pickle: memo entry " + std::to_string(index) + " missing");
    return it->second;
  }
  void push_global(const std::string& name) {
    if (!allowed_global(name)) {
      bad("refusing pickle global '" + name +
          "': not allowed in a weights file (only state-dict tensors are loaded; nothing is executed)");
    }
    auto v = make(Value::Kind::global);
    v->text = name;
    push(v);
  }

  static std::vector<std::int64_t> int_tuple(const Value& v, const char* what, const Unpickler& u) {
    if (v.kind != Value::Kind::tuple || v.items.size() > kMaxDims) u.bad(std::string("bad tensor ") + what);
    std::vector<std::int64_t> out;
    for (const auto& i : v.items) {
      if (i->kind != Value::Kind::integer || i->integer < 0) u.bad(std::string("bad tensor ") + what);
      out.push_back(i->integer);
    }
    return out;
  }

  Ref rebuild_tensor(const std::vector<Ref>& a) {
    if (a.size() < 4 || a[0]->kind != Value::Kind::tensor || a[1]->kind != Value::Kind::integer)
      bad("_rebuild_tensor_v2 with unexpected arguments");
    const at::Tensor& storage = a[0]->tensor;
    std::int64_t offset = a[1]->integer;
    auto size = int_tuple(*a[2], "size", *this);
    auto stride = int_tuple(*a[3], "stride", *this);
    if (size.size() != stride.size()) bad("tensor size and stride differ in length");
    // The last element the view touches must lie inside the storage (checked without overflow).
    const std::int64_t numel = storage.numel();
    auto overflow = [&] {
      bad("tensor view (offset " + std::to_string(offset) + ", size " + std::string(c10::str(at::IntArrayRef(size))) +
          ", stride " + std::string(c10::str(at::IntArrayRef(stride))) + ") exceeds its storage of " +
          std::to_string(numel) + " elements");
    };
    bool empty = false;
    for (auto s : size) empty = empty || s == 0;
    if (offset < 0 || (!empty && offset >= numel) || offset > numel) overflow();
    if (!empty) {
      std::int64_t last = offset;  // index of the last element touched
      for (std::size_t i = 0; i < size.size(); ++i) {
        if (stride[i] != 0 && size[i] - 1 > (numel - 1 - last) / stride[i]) overflow();
        last += (size[i] - 1) * stride[i];
      }
    }
    // Stride-0 dimensions (expanded tensors) can make a view larger than its storage: bound the element
    // count so that a few bytes cannot turn into a multi-GB tensor when the view is copied.
    if (!empty) {
      std::int64_t count = 1;
      for (auto s : size) {
        if (s > kMaxViewElements / count) {
          bad("tensor view of size " + std::string(c10::str(at::IntArrayRef(size))) + " has more than " +
              std::to_string(kMaxViewElements) + " elements and only " + std::to_string(numel) + " stored");
        }
        count *= s;
      }
      if (count > numel && count > kMaxExpandedElements) {
        bad("tensor view of size " + std::string(c10::str(at::IntArrayRef(size))) + " expands " +
            std::to_string(numel) + " stored elements to " + std::to_string(count));
      }
    }
    auto v = make(Value::Kind::tensor);
    v->tensor = empty ? torch::empty(size, storage.options()) : storage.as_strided(size, stride, offset);
    return v;
  }

  Ref call(const Ref& callable, const Ref& args) {
    if (callable->kind != Value::Kind::global) bad("REDUCE on something that is not an allowed global");
    if (args->kind != Value::Kind::tuple) bad("REDUCE arguments are not a tuple");
    const std::string& f = callable->text;
    if (f == "collections.OrderedDict") {
      auto d = make(Value::Kind::dict);
      if (!args->items.empty()) bad("OrderedDict built with arguments is not supported");
      return d;
    }
    if (f == "torch._utils._rebuild_tensor_v2") return rebuild_tensor(args->items);
    if (f == "torch._utils._rebuild_parameter") {
      if (args->items.empty() || args->items[0]->kind != Value::Kind::tensor) bad("bad _rebuild_parameter");
      return args->items[0];
    }
    bad("'" + f + "' cannot be called");
  }

  const unsigned char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string name_;
  const PersistentLoader& load_;
  std::vector<Ref> stack_;
  std::vector<std::size_t> marks_;
  std::unordered_map<std::uint64_t, Ref> memo_;
  std::unordered_set<const Value*> contained_;  // values placed in a container (kept alive by it)
  std::size_t objects_ = 0;
};

}  // namespace

bool storage_dtype(const std::string& global, at::ScalarType* type, std::size_t* element_size) {
  for (const auto& s : kStorages) {
    if (global == s.name) {
      *type = s.type;
      *element_size = s.bytes;
      return true;
    }
  }
  return false;
}

Ref unpickle(const std::string& bytes, const std::string& name, const PersistentLoader& persistent_load) {
  Unpickler u(bytes, name, persistent_load);
  return u.run();
}

}  // namespace lrf::pickle
