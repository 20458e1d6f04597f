#pragma once
// The AS5311 magnetic linear encoder (ams AS5311 datasheet: 12-bit position over one pole
// pair of a 2.0 mm magnetic strip, 2000 um / 4096 = 0.488 um; SSI output, docs/closedloop.md
// section 2). The SSI frame is 18 bits, MSB first:
//   D11..D0 (position within the pole pair), OCF, COF, LIN, MagINC, MagDEC, EvenPAR
// OCF = 1: offset compensation finished; COF = 1: CORDIC overflow (data invalid); LIN = 1:
// linearity alarm (data questionable); MagINC = MagDEC = 1: magnetic field out of range.
// EvenPAR makes the number of ones in the 18 bits even. A frame is accepted when parity
// holds, OCF = 1, COF = 0, LIN = 0 and not (MagINC and MagDEC).
// The position is absolute only within a pole pair; crossing poles is unwrapped by taking the
// change of count modulo 4096 into [-2048, 2048) (valid while the head moves < 1 mm between
// two reads: 10 m/s at 10 kHz).
#include <cstdint>
#include <optional>
#include <random>
#include <vector>

namespace amctl::closedloop {

inline constexpr double kAs5311PolePairMm = 2.0;
inline constexpr int kAs5311Counts = 4096;
inline constexpr double kAs5311ResolutionMm = kAs5311PolePairMm / kAs5311Counts;

/// The fields of one SSI frame.
struct As5311Frame {
  std::uint16_t position = 0;  ///< 0..4095
  bool ocf = true, cof = false, lin = false, mag_inc = false, mag_dec = false;
};

/// The 18-bit frame (bit 17 = D11 first on the wire, bit 0 = parity) with even parity.
[[nodiscard]] std::uint32_t encode_frame(const As5311Frame& f);
/// Decoding result: the fields, whether parity holds and whether the data may be used.
struct DecodedFrame {
  As5311Frame frame;
  bool parity_ok = false;
  bool valid = false;  ///< parity_ok && ocf && !cof && !lin && !(mag_inc && mag_dec)
};
[[nodiscard]] DecodedFrame decode_frame(std::uint32_t bits18);

/// Encoder options.
struct EncoderParameters {
  /// One count [mm]: the AS5311's 2.0 mm / 4096 by default. Coarser values model a coarser
  /// encoder (fewer counts per 2 mm pole pair in the same 12-bit frame); finer ones do not
  /// fit the frame and are refused.
  double resolution_mm = kAs5311ResolutionMm;
  double noise_rms_um = 0.3;        ///< white noise on the sensed position before quantising [um]
  double latency_s = 100e-6;        ///< sensing to frame available (internal sampling + SSI)
  double corrupt_probability = 0.0; ///< a bit of the frame flipped on the wire, per read
  std::uint64_t seed = 1;           ///< noise and corruption (deterministic)
  void validate() const;
};

/// Reads the strip: quantised count with noise, framed, possibly corrupted, decoded and
/// unwrapped across poles. Holds the last good value when a frame is rejected.
class As5311Encoder {
 public:
  As5311Encoder(const EncoderParameters& p, double start_mm);
  /// One read of the head at true position x_mm; returns the unwrapped position [mm] (the last
  /// good one if this frame is rejected).
  double read(double x_mm);
  [[nodiscard]] std::uint64_t rejected_frames() const { return rejected_; }
  [[nodiscard]] std::uint64_t reads() const { return reads_; }
  [[nodiscard]] bool last_valid() const { return last_valid_; }

 private:
  EncoderParameters p_;
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> uni_{0.0, 1.0};
  /// Standard normal samples drawn once from rng_ (the sensor noise is white noise of a
  /// given rms; a table cycled by a xorshift index costs a few ns per read instead of a
  /// Gaussian draw).
  std::vector<double> normals_;
  std::uint64_t pick_ = 0;
  std::int64_t turns_counts_ = 0;  ///< unwrapped count of the last good frame
  int last_count_ = 0;
  double offset_mm_ = 0.0;         ///< strip zero so that the first read returns start_mm
  double res_mm_ = kAs5311ResolutionMm;  ///< one count
  double inv_res_ = 1.0 / kAs5311ResolutionMm;
  int counts_ = kAs5311Counts;     ///< counts per pole pair
  std::uint64_t rejected_ = 0, reads_ = 0;
  bool last_valid_ = true;
};

}  // namespace amctl::closedloop
