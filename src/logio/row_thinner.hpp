#pragma once
// Which rows of a long log are kept within a row budget, decided in one pass (private to
// ftid_logio: readLogThinned; docs/log-format.md "Limits"). Rows come in two classes, the robot
// holding still and moving; each class is cut into blocks of block_rows consecutive rows of that
// class, and a block is kept when its index is a multiple of the class's stride. When the kept
// rows pass the budget, the class holding more of them doubles its stride and its rows in blocks
// that are no longer multiples are dropped. Identity: a row is kept iff
// (its index within its class / block_rows) % stride(class) == 0 for the final strides, so the
// result does not depend on when the strides grew.
#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace ftid::logio {

class RowThinner {
 public:
  /// Needs 1 <= block_rows and 2 * block_rows <= budget_rows (thinBlockRows gives that): the first
  /// block of each class, which no stride leaves out, must fit within the budget together.
  RowThinner(std::size_t budget_rows, std::size_t block_rows) : budget_(budget_rows), block_(block_rows) {
    if (block_rows == 0 || 2 * block_rows > budget_rows) {
      throw std::invalid_argument("RowThinner: blocks of " + std::to_string(block_rows) + " rows do not fit twice in " +
                                  std::to_string(budget_rows));
    }
  }

  /// The next row, of class `still` (else moving): true if it is to be stored now.
  bool offer(bool still) {
    const std::size_t c = still ? 1 : 0;
    const std::size_t block = count_[c]++ / block_;
    if (block % stride_[c] != 0) return false;
    kept_.push_back({c, block});
    ++kept_of_[c];
    return true;
  }

  /// True when the stored rows are more than the budget: then call thin() and apply its `keep`.
  bool over() const { return kept_.size() > budget_; }

  /// Doubles the stride of the class holding more of the stored rows (until within the budget)
  /// and returns, per stored row in order, whether it stays.
  std::vector<char> thin() {
    while (kept_of_[0] + kept_of_[1] > budget_) {
      const std::size_t c = kept_of_[1] > kept_of_[0] ? 1 : 0;
      stride_[c] *= 2;
      kept_of_[c] = 0;
      for (const Kept& k : kept_) {
        if (k.cls == c && k.block % stride_[c] == 0) ++kept_of_[c];
      }
    }
    std::vector<char> keep(kept_.size());
    std::size_t n = 0;
    for (std::size_t i = 0; i < kept_.size(); ++i) {
      keep[i] = kept_[i].block % stride_[kept_[i].cls] == 0 ? 1 : 0;
      if (keep[i] != 0) kept_[n++] = kept_[i];
    }
    kept_.resize(n);
    return keep;
  }

  std::size_t rows(bool still) const { return count_[still ? 1 : 0]; }
  std::size_t stride(bool still) const { return stride_[still ? 1 : 0]; }

 private:
  struct Kept {
    std::size_t cls;
    std::size_t block;
  };
  std::size_t budget_;
  std::size_t block_;
  std::array<std::size_t, 2> count_{0, 0};   ///< rows offered per class (0 moving, 1 still)
  std::array<std::size_t, 2> stride_{1, 1};  ///< blocks
  std::array<std::size_t, 2> kept_of_{0, 0};
  std::vector<Kept> kept_;
};

}  // namespace ftid::logio
