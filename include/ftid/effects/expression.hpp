#pragma once
// A scalar expression of a sample's signals, for the user's own effect `expr(axis: expression)`
// (docs/effects.md, "Your own effect without C++"). Grammar (usual precedence, ^ binds right):
//
//   expression := term (('+' | '-') term)*
//   term       := unary (('*' | '/') unary)*
//   unary      := '-' unary | power            (so -a^2 = -(a^2))
//   power      := primary ('^' unary)?         (right-associative: a^b^c = a^(b^c))
//   primary    := number | signal | function '(' expression ')' | '(' expression ')' | pi
//   function   := sin cos tan exp log sqrt abs tanh sign
//
// A signal is any name of ftid/effects/signal_source.hpp (t, temp, q1..q6, qd1..qd6, wx.., alx..,
// ax.., gx.., or an extra log column). The expression is compiled once into a postfix program;
// evaluate() runs it on a fixed-size stack: no allocation, no exception (real-time safe).
#include <cstdint>
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"
#include "ftid/effects/signal_source.hpp"

namespace ftid::effects {

class Expression {
 public:
  static constexpr int kMaxOps = 128;    ///< longest program (numbers, signals and operators)
  static constexpr int kMaxDepth = 32;   ///< deepest evaluation stack

  /// Compiles `text`. Throws ConfigError naming the expression and the character position of the
  /// first error (unknown function, unbalanced parenthesis, missing operand, too long).
  static Expression parse(const std::string& text);

  /// The value for one sample; NaN when a signal is missing or the arithmetic is undefined there
  /// (log of a negative number, 0/0). Real-time safe.
  double evaluate(const SampleContext& ctx) const noexcept;

  /// The signals the expression reads, each once, in order of first use.
  const std::vector<SignalSource>& signals() const { return signals_; }
  /// The expression without blanks (its canonical text, used in effect and parameter names).
  const std::string& text() const { return text_; }
  /// Signal bits (effects::Signal) of all signals read.
  std::uint32_t signalBits() const;

  enum class OpKind : std::uint8_t { kNumber, kSignal, kAdd, kSub, kMul, kDiv, kPow, kNeg, kFunc };
  enum class Func : std::uint8_t { kSin, kCos, kTan, kExp, kLog, kSqrt, kAbs, kTanh, kSign };
  struct Op {
    OpKind kind = OpKind::kNumber;
    Func func = Func::kSin;
    int index = 0;       ///< signal index (kSignal)
    double value = 0.0;  ///< constant (kNumber)
  };

 private:
  friend class ExpressionParser;
  std::vector<Op> ops_;
  std::vector<SignalSource> signals_;
  std::string text_;
};

}  // namespace ftid::effects
