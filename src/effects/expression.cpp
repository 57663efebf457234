// Expressions of signals for the user's own effect (include/ftid/effects/expression.hpp).
#include "ftid/effects/expression.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "ftid/common/error.hpp"

namespace ftid::effects {

/// Recursive descent over the text, emitting postfix operations as it returns.
class ExpressionParser {
 public:
  explicit ExpressionParser(std::string text) : text_(std::move(text)) {}

  Expression run() {
    skipBlanks();
    if (pos_ >= text_.size()) fail("is empty (e.g. grip*qd6)");
    expression();
    skipBlanks();
    if (pos_ < text_.size()) fail(std::string("has an unexpected '") + text_[pos_] + "'");
    checkDepth();
    for (char c : text_) {
      if (!std::isspace(static_cast<unsigned char>(c))) out_.text_ += c;
    }
    return std::move(out_);
  }

 private:
  using Kind = Expression::OpKind;

  [[noreturn]] void fail(const std::string& what) const {
    throw ConfigError("expression '" + text_ + "' " + what + " (at character " + std::to_string(pos_ + 1) + ")");
  }
  void skipBlanks() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  bool accept(char c) {
    skipBlanks();
    if (pos_ < text_.size() && text_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  void emit(Expression::Op op) {
    if (static_cast<int>(out_.ops_.size()) >= Expression::kMaxOps) {
      fail("is too long (at most " + std::to_string(Expression::kMaxOps) + " numbers, signals and operators)");
    }
    out_.ops_.push_back(op);
  }
  void emitKind(Kind k) {
    Expression::Op op;
    op.kind = k;
    emit(op);
  }

  void expression() {
    term();
    for (;;) {
      if (accept('+')) {
        term();
        emitKind(Kind::kAdd);
      } else if (accept('-')) {
        term();
        emitKind(Kind::kSub);
      } else {
        return;
      }
    }
  }
  void term() {
    unary();
    for (;;) {
      if (accept('*')) {
        unary();
        emitKind(Kind::kMul);
      } else if (accept('/')) {
        unary();
        emitKind(Kind::kDiv);
      } else {
        return;
      }
    }
  }
  void power() {
    primary();
    if (accept('^')) {
      unary();  // right-associative (a^b^c = a^(b^c)) and -a^2 = -(a^2), as in mathematics
      emitKind(Kind::kPow);
    }
  }
  void unary() {
    if (++nesting_ > 64) fail("nests too deeply");
    if (accept('-')) {
      unary();
      emitKind(Kind::kNeg);
    } else if (accept('+')) {
      unary();
    } else {
      power();
    }
    --nesting_;
  }
  void primary() {
    skipBlanks();
    if (pos_ >= text_.size()) fail("ends where a number, a signal or '(' is needed");
    const char c = text_[pos_];
    if (accept('(')) {
      expression();
      if (!accept(')')) fail("misses a ')'");
    } else if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
      number();
    } else if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      name();
    } else {
      fail(std::string("has '") + c + "' where a number, a signal or '(' is needed");
    }
  }
  void number() {
    const char* begin = text_.c_str() + pos_;
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (end == begin || !std::isfinite(v)) fail("has a number that cannot be read");
    pos_ += static_cast<std::size_t>(end - begin);
    Expression::Op op;
    op.kind = Kind::kNumber;
    op.value = v;
    emit(op);
  }
  void name() {
    const std::size_t start = pos_;
    while (pos_ < text_.size() &&
           (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_' || text_[pos_] == '.')) {
      ++pos_;
    }
    const std::string id = text_.substr(start, pos_ - start);
    if (accept('(')) {
      function(id, start);
      return;
    }
    Expression::Op op;
    if (id == "pi") {
      op.kind = Kind::kNumber;
      op.value = M_PI;
    } else {
      op.kind = Kind::kSignal;
      op.index = signalIndex(id);
    }
    emit(op);
  }
  void function(const std::string& id, std::size_t start) {
    static const std::array<std::pair<const char*, Expression::Func>, 9> kFuncs{{
        {"sin", Expression::Func::kSin}, {"cos", Expression::Func::kCos}, {"tan", Expression::Func::kTan},
        {"exp", Expression::Func::kExp}, {"log", Expression::Func::kLog}, {"sqrt", Expression::Func::kSqrt},
        {"abs", Expression::Func::kAbs}, {"tanh", Expression::Func::kTanh}, {"sign", Expression::Func::kSign},
    }};
    const auto it = std::find_if(kFuncs.begin(), kFuncs.end(), [&](const auto& f) { return id == f.first; });
    if (it == kFuncs.end()) {
      pos_ = start;
      fail("calls an unknown function '" + id + "' (known: sin cos tan exp log sqrt abs tanh sign)");
    }
    expression();
    if (!accept(')')) fail("misses the ')' of " + id + "(");
    Expression::Op op;
    op.kind = Kind::kFunc;
    op.func = it->second;
    emit(op);
  }
  int signalIndex(const std::string& id) {
    for (std::size_t k = 0; k < out_.signals_.size(); ++k) {
      if (out_.signals_[k].name() == id) return static_cast<int>(k);
    }
    out_.signals_.push_back(SignalSource::parse(id));
    return static_cast<int>(out_.signals_.size()) - 1;
  }
  /// The stack depth the program needs, bounded by Expression::kMaxDepth.
  void checkDepth() const {
    int depth = 0;
    for (const auto& op : out_.ops_) {
      const bool pushes = op.kind == Kind::kNumber || op.kind == Kind::kSignal;
      const bool unary = op.kind == Kind::kNeg || op.kind == Kind::kFunc;
      depth += pushes ? 1 : unary ? 0 : -1;
      if (depth > Expression::kMaxDepth) {
        throw ConfigError("expression '" + text_ + "' needs more than " + std::to_string(Expression::kMaxDepth) +
                          " intermediate values; write it with fewer nested parentheses");
      }
    }
  }

  std::string text_;
  std::size_t pos_ = 0;
  int nesting_ = 0;
  Expression out_;
};

Expression Expression::parse(const std::string& text) { return ExpressionParser(text).run(); }

namespace {

double applyFunc(Expression::Func f, double x) noexcept {
  switch (f) {
    case Expression::Func::kSin: return std::sin(x);
    case Expression::Func::kCos: return std::cos(x);
    case Expression::Func::kTan: return std::tan(x);
    case Expression::Func::kExp: return std::exp(x);
    case Expression::Func::kLog: return x > 0.0 ? std::log(x) : std::numeric_limits<double>::quiet_NaN();
    case Expression::Func::kSqrt: return x >= 0.0 ? std::sqrt(x) : std::numeric_limits<double>::quiet_NaN();
    case Expression::Func::kAbs: return std::abs(x);
    case Expression::Func::kTanh: return std::tanh(x);
    case Expression::Func::kSign: return x > 0.0 ? 1.0 : x < 0.0 ? -1.0 : 0.0;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

double applyBinary(Expression::OpKind k, double a, double b) noexcept {
  switch (k) {
    case Expression::OpKind::kAdd: return a + b;
    case Expression::OpKind::kSub: return a - b;
    case Expression::OpKind::kMul: return a * b;
    case Expression::OpKind::kDiv: return b != 0.0 ? a / b : std::numeric_limits<double>::quiet_NaN();
    case Expression::OpKind::kPow: return std::pow(a, b);
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace

double Expression::evaluate(const SampleContext& ctx) const noexcept {
  std::array<double, kMaxDepth> stack{};
  int top = 0;  // number of values on the stack; parse() proved it stays within kMaxDepth
  for (const Op& op : ops_) {
    switch (op.kind) {
      case OpKind::kNumber: stack[static_cast<std::size_t>(top++)] = op.value; break;
      case OpKind::kSignal:
        stack[static_cast<std::size_t>(top++)] = signals_[static_cast<std::size_t>(op.index)].read(ctx);
        break;
      case OpKind::kNeg: stack[static_cast<std::size_t>(top - 1)] = -stack[static_cast<std::size_t>(top - 1)]; break;
      case OpKind::kFunc:
        stack[static_cast<std::size_t>(top - 1)] = applyFunc(op.func, stack[static_cast<std::size_t>(top - 1)]);
        break;
      default:
        --top;
        stack[static_cast<std::size_t>(top - 1)] =
            applyBinary(op.kind, stack[static_cast<std::size_t>(top - 1)], stack[static_cast<std::size_t>(top)]);
    }
  }
  const double v = top == 1 ? stack[0] : std::numeric_limits<double>::quiet_NaN();
  return std::isfinite(v) ? v : std::numeric_limits<double>::quiet_NaN();
}

std::uint32_t Expression::signalBits() const {
  std::uint32_t bits = kSignalNone;
  for (const auto& s : signals_) bits |= s.signals();
  return bits;
}

}  // namespace ftid::effects
