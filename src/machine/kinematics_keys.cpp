#include "kinematics_keys.hpp"

#include <algorithm>
#include <variant>

namespace amctl::machine::detail {
namespace {

Bound bound_of(kinematics::KeyBound b) {
  switch (b) {
    case kinematics::KeyBound::finite: return Bound::finite;
    case kinematics::KeyBound::non_negative: return Bound::non_negative;
    case kinematics::KeyBound::positive: return Bound::positive;
  }
  return Bound::finite;
}

template <class K>
BoundKey erase(const kinematics::ParamKey<K>& d, K* k) {
  BoundKey b;
  b.section = d.section;
  b.key = d.key;
  b.bound = bound_of(d.bound);
  b.unit = d.unit;
  b.description = d.description;
  b.choices = d.choices;
  b.unwritten_default = d.unwritten_default;
  if (d.number) {
    b.kind = BoundKey::Kind::number;
    if (k) b.number = [f = d.number, k](std::string_view i, bool c) { return f(*k, i, c); };
  } else if (d.optional_number) {
    b.kind = BoundKey::Kind::optional_number;
    if (k) b.optional_number = [f = d.optional_number, k](std::string_view i, bool c) { return f(*k, i, c); };
  } else if (d.text) {
    b.kind = BoundKey::Kind::text;
    if (k) b.text = [f = d.text, k](std::string_view i, bool c) { return f(*k, i, c); };
  } else if (d.boolean) {
    b.kind = BoundKey::Kind::boolean;
    if (k) b.boolean = [f = d.boolean, k](std::string_view i, bool c) { return f(*k, i, c); };
  } else {
    b.kind = BoundKey::Kind::choice;
    if (k) {
      b.get_index = [f = d.get_index, k](std::string_view i) { return f(*k, i); };
      b.set_index = [f = d.set_index, k](std::string_view i, int v) { return f(*k, i, v); };
    }
  }
  if (d.instances && k) b.instances = [f = d.instances, k] { return f(*k); };
  return b;
}

template <class K>
void append(std::vector<BoundKey>& out, K* k) {
  for (const auto& d : K::keys()) out.push_back(erase(d, k));
}

template <std::size_t... I>
void append_all(std::vector<BoundKey>& out, std::index_sequence<I...>) {
  (append<std::variant_alternative_t<I, kinematics::Params>>(out, nullptr), ...);
}

}  // namespace

std::vector<BoundKey> bound_keys(Machine& m) {
  std::vector<BoundKey> out;
  append(out, &m.extruder);
  for (BoundKey& b : out) b.extruder = true;
  std::visit([&](auto& k) { append(out, &k); }, m.kinematics);
  return out;
}

const BoundKey* find_bound(const std::vector<BoundKey>& keys, std::string_view section,
                           std::string_view key, std::string_view instance) {
  for (const BoundKey& b : keys) {
    if (b.section != section || b.key != key) continue;
    // Asking with create = true makes what holds the field: the caller assigns it next.
    const bool applies = b.number            ? b.number(instance, true) != nullptr
                         : b.optional_number ? b.optional_number(instance, true) != nullptr
                         : b.text            ? b.text(instance, true) != nullptr
                         : b.boolean         ? b.boolean(instance, true) != nullptr
                                             : !instance.empty() || b.section != "carriage";
    if (applies) return &b;
  }
  return nullptr;
}

std::vector<std::string_view> kinematics_with_section(std::string_view section) {
  std::vector<std::string_view> out;
  const auto names = kinematics::names();
  for (std::size_t i = 0; i < names.size(); ++i) {
    std::vector<BoundKey> keys;
    const kinematics::Params p = *kinematics::params_named(names[i]);
    std::visit([&](const auto& k) { append<std::decay_t<decltype(k)>>(keys, nullptr); }, p);
    if (std::any_of(keys.begin(), keys.end(), [&](const BoundKey& b) { return b.section == section; })) {
      out.push_back(names[i]);
    }
  }
  return out;
}

std::vector<BoundKey> all_kinematics_keys() {
  std::vector<BoundKey> all;
  append<kinematics::Extruder>(all, nullptr);
  append_all(all, std::make_index_sequence<std::variant_size_v<kinematics::Params>>());
  std::vector<BoundKey> out;
  for (const BoundKey& b : all) {
    const bool seen = std::any_of(out.begin(), out.end(), [&](const BoundKey& o) {
      return o.section == b.section && o.key == b.key;
    });
    if (!seen) out.push_back(b);
  }
  return out;
}

bool owned_stepper(const Machine& m, std::string_view key) {
  return std::visit([&](const auto& k) { return k.owns_stepper(key); }, m.kinematics);
}

kinematics::Unit drive_train_unit(const Machine& m, std::string_view key) {
  return std::visit([&](const auto& k) { return std::decay_t<decltype(k)>::unit_of(key); }, m.kinematics);
}

}  // namespace amctl::machine::detail
