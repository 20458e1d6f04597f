#include "amctl/formats/meatpack.hpp"

namespace amctl::formats {
namespace {

constexpr std::uint8_t kSignal = 0xFF;
constexpr std::uint8_t kPackingOn = 251;
constexpr std::uint8_t kPackingOff = 250;
constexpr std::uint8_t kResetAll = 249;
constexpr std::uint8_t kNoSpacesOn = 247;
constexpr std::uint8_t kNoSpacesOff = 246;
constexpr unsigned kWhole = 0xF;  // nibble: the character follows as a whole byte

/// Parameter letters before which the writer dropped a space in a G line.
bool is_parameter_letter(char c) {
  switch (c) {
    case 'X': case 'Y': case 'Z': case 'E': case 'F':  // G0, G1
    case 'I': case 'J': case 'R':                      // G2, G3
    case 'S':                                          // G4
    case 'G': case 'P': case 'W': case 'H': case 'C': case 'A':  // G29
      return true;
    default:
      return false;
  }
}

}  // namespace

void MeatPackDecoder::reset() { *this = MeatPackDecoder{}; }

char MeatPackDecoder::unpack(unsigned code) const {
  static constexpr char kTable[15] = {'0', '1', '2', '3', '4', '5', '6', '7',
                                      '8', '9', '.', ' ', '\n', 'G', 'X'};
  if (code == 11 && no_spaces_) return 'E';
  return kTable[code];
}

void MeatPackDecoder::emit(char c, std::string& out) {
  // A line that starts with G and a digit lost its spaces in the writer: they go back in.
  switch (line_) {
    case Line::start: line_ = c == 'G' ? Line::after_g : Line::other; break;
    case Line::after_g: line_ = c >= '0' && c <= '9' ? Line::g_command : Line::other; break;
    case Line::g_command:
      if (last_ != ' ' && is_parameter_letter(c)) {
        out.push_back(' ');
        last_ = ' ';
      }
      break;
    case Line::other: break;
  }
  if (c == '\n') {
    line_ = Line::start;
    if (last_ == '\n') return;  // no empty lines
  }
  out.push_back(c);
  last_ = c;
}

void MeatPackDecoder::byte(std::uint8_t b, std::string& out) {
  if (!packing_) {
    emit(static_cast<char>(b), out);
    return;
  }
  if (whole_bytes_due_ > 0) {
    emit(static_cast<char>(b), out);
    if (held_ != 0) {
      emit(held_, out);
      held_ = 0;
    }
    --whole_bytes_due_;
    return;
  }
  const unsigned low = b & 0xFu;
  const unsigned high = b >> 4;
  if (low == kWhole) {
    ++whole_bytes_due_;
    if (high == kWhole) {
      ++whole_bytes_due_;
    } else {
      held_ = unpack(high);
    }
    return;
  }
  const char first = unpack(low);
  emit(first, out);
  if (first == '\n') return;  // the high nibble pads the line's last byte
  if (high == kWhole) {
    ++whole_bytes_due_;
  } else {
    emit(unpack(high), out);
  }
}

void MeatPackDecoder::decode(std::span<const std::uint8_t> in, std::string& out) {
  for (const std::uint8_t b : in) {
    if (b == kSignal) {
      if (signal_ > 0) {
        command_due_ = true;
        signal_ = 0;
      } else {
        ++signal_;
      }
      continue;
    }
    if (command_due_) {
      command_due_ = false;
      switch (b) {
        case kPackingOn: packing_ = true; break;
        case kPackingOff: packing_ = false; break;
        case kResetAll: packing_ = false; break;
        case kNoSpacesOn: no_spaces_ = true; break;
        case kNoSpacesOff: no_spaces_ = false; break;
        default: break;  // query and unassigned commands change nothing
      }
      continue;
    }
    if (signal_ > 0) {  // a lone 0xFF: a byte whose nibbles are both "whole byte follows"
      signal_ = 0;
      byte(kSignal, out);
    }
    byte(b, out);
  }
}

}  // namespace amctl::formats
