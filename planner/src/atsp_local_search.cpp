// Iterated local search for the ATSP on an array tour (tour[position] = node, pos[node]).
//
// Moves, both tried from every node a whose don't-look bit is off:
// - the orientation-preserving 3-opt "segment swap". With a, b, c in tour order and the
//   segments S1 = a+..b, S2 = b+..c, the arcs (a,a+), (b,b+), (c,c+) are replaced by (a,b+),
//   (c,a+), (b,c+): a S1 S2 c+ becomes a S2 S1 c+. No segment is reversed, so it suits
//   asymmetric costs; Or-opt (moving a short segment elsewhere) is the case of a short S1 or S2.
//   From a it tries the new arc (a, b+) over a's candidate successors, then closes either with
//   (c, a+) over a+'s candidate predecessors or with (b, c+) over b's candidate successors,
//   keeping the partial gain positive (the Lin-Kernighan gain criterion);
// - the segment reversal (2-opt), priced exactly with prefix sums of the per-arc cost change of
//   reversing; it matters on nearly symmetric costs such as the planner's travel times.
//
// Kick: a random local double bridge A B C D -> A D C B (B, C, D short and adjacent), which
// changes four arcs and cannot be undone by one segment swap. Acceptance: better or equal, so
// the search drifts across the plateaus of equal-cost tours that tie-heavy instances have, plus
// a forced step to a worse tour after many rejections in a row (a random walk out of basins).
#include "atsp_internal.hpp"

#include <algorithm>
#include <cstdlib>

namespace vdbmap::planner::atsp {
namespace {

/// SplitMix64: tiny, and the same sequence on every platform (unlike std distributions).
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, bound), 0 < bound < 2^31 (multiply-shift of the high 32 bits; the bias is
  /// negligible for our bounds).
  int below(int bound) { return int(((next() >> 32) * std::uint64_t(bound)) >> 32); }

 private:
  std::uint64_t state_;
};

// Longest block a kick moves: kicks stay local, so the descent that follows is short.
constexpr int kMaxKickBlock = 30;
// After n / 4 rejected rounds in a row without a new best, the next kicked tour is accepted
// even if worse. Without it the search stays for good in deep basins (ftv35 and ftv38 stopped
// 2 above the optimum for every seed); with it every TSPLIB instance up to n = 171 reaches its
// optimum within tens of milliseconds (bench_atsp). n / 2 and n / 1 did about as well.
constexpr int kRejectionsPerWalkStepDivisor = 4;

class TourSearch {
 public:
  TourSearch(const AtspInstance& instance, const CandidateLists& candidates)
      : n_(instance.n),
        costs_(instance.costs.data()),
        candidates_(candidates),
        tour_(std::size_t(n_)),
        pos_(std::size_t(n_)),
        reversal_change_(std::size_t(n_)),
        reversal_prefix_(std::size_t(n_) + 1),
        queue_(std::size_t(n_)),
        queued_(std::size_t(n_), 0) {}

  void setTour(const std::vector<int>& order) {
    for (int p = 0; p < n_; ++p) {
      tour_[std::size_t(p)] = order[std::size_t(p)];
      pos_[std::size_t(order[std::size_t(p)])] = p;
    }
    cost_ = 0;
    for (int p = 0; p < n_; ++p) cost_ += arc(tour_[std::size_t(p)], succ(tour_[std::size_t(p)]));
    refreshArcs(0, n_);
    for (int p = 0; p < n_; ++p) activate(tour_[std::size_t(p)]);
  }

  std::int64_t cost() const { return cost_; }
  std::vector<int> order() const { return tour_; }

  /// Applies improving moves until none is left among the active nodes, or the deadline passes.
  void descend(const Deadline& deadline) {
    std::uint32_t pops = 0;
    while (queue_size_ > 0) {
      if ((++pops & 127) == 0 && deadline.passed()) return;
      const int a = queue_[std::size_t(queue_head_)];
      queue_head_ = queue_head_ + 1 == n_ ? 0 : queue_head_ + 1;
      --queue_size_;
      queued_[std::size_t(a)] = 0;
      improveFrom(a);
    }
  }

  /// The local double bridge A B C D -> A D C B on three short adjacent blocks.
  void kick(Random& random) {
    const int max_block = std::max(1, std::min(kMaxKickBlock, (n_ - 1) / 3));
    const int start = random.below(n_);
    const int len_b = 1 + random.below(max_block), len_c = 1 + random.below(max_block);
    const int len_d = 1 + random.below(max_block);
    const int a = at(start - 1), b0 = at(start), b1 = at(start + len_b - 1), c0 = at(start + len_b);
    const int c1 = at(start + len_b + len_c - 1), d0 = at(start + len_b + len_c);
    const int d1 = at(start + len_b + len_c + len_d - 1), e = at(start + len_b + len_c + len_d);
    cost_ += arc(a, d0) + arc(d1, c0) + arc(c1, b0) + arc(b1, e) - arc(a, b0) - arc(b1, c0) - arc(c1, d0) - arc(d1, e);
    buffer_.clear();
    for (int i = 0; i < len_d; ++i) buffer_.push_back(at(start + len_b + len_c + i));
    for (int i = 0; i < len_c; ++i) buffer_.push_back(at(start + len_b + i));
    for (int i = 0; i < len_b; ++i) buffer_.push_back(at(start + i));
    writeBack(start);
    for (const int node : {a, b0, b1, c0, c1, d0, d1, e}) activate(node);
  }

  struct Snapshot {
    std::vector<int> tour, pos;
    std::vector<std::int64_t> reversal_change;
    std::int64_t cost = 0;
  };
  void save(Snapshot& snapshot) const {
    snapshot.tour = tour_;
    snapshot.pos = pos_;
    snapshot.reversal_change = reversal_change_;
    snapshot.cost = cost_;
  }
  void restore(const Snapshot& snapshot) {
    tour_ = snapshot.tour;
    pos_ = snapshot.pos;
    reversal_change_ = snapshot.reversal_change;
    prefix_valid_ = false;
    cost_ = snapshot.cost;
    while (queue_size_ > 0) {  // an interrupted descent may leave nodes queued
      queued_[std::size_t(queue_[std::size_t(queue_head_)])] = 0;
      queue_head_ = queue_head_ + 1 == n_ ? 0 : queue_head_ + 1;
      --queue_size_;
    }
  }

 private:
  std::int64_t arc(int from, int to) const { return costs_[std::size_t(from) * std::size_t(n_) + std::size_t(to)]; }
  int at(int position) const { return tour_[std::size_t(wrap(position))]; }
  int wrap(int position) const { return position < 0 ? position + n_ : (position >= n_ ? position - n_ : position); }
  int succ(int node) const { return at(pos_[std::size_t(node)] + 1); }
  int pred(int node) const { return at(pos_[std::size_t(node)] - 1); }
  /// Steps forward from `from` to `node`, in [0, n).
  int offset(int from, int node) const { return wrap(pos_[std::size_t(node)] - pos_[std::size_t(from)]); }
  const int* outCandidates(int node) const { return &candidates_.out[std::size_t(node) * std::size_t(candidates_.k)]; }
  const int* inCandidates(int node) const { return &candidates_.in[std::size_t(node) * std::size_t(candidates_.k)]; }

  void activate(int node) {
    if (queued_[std::size_t(node)]) return;
    queued_[std::size_t(node)] = 1;
    queue_[std::size_t(wrap(queue_head_ + queue_size_))] = node;
    ++queue_size_;
  }

  /// First improving move that removes the arc (a, a+): a segment swap, else a reversal.
  bool improveFrom(int a) { return trySegmentSwap(a) || tryReversal(a); }

  /// Segment swaps with a as the tail of the first removed arc.
  bool trySegmentSwap(int a) {
    const int a_next = succ(a);
    const std::int64_t removed_a = arc(a, a_next);
    const int k = candidates_.k;
    const int* out_a = outCandidates(a);
    for (int i = 0; i < k; ++i) {
      const int b_next = out_a[i];
      const std::int64_t gain1 = removed_a - arc(a, b_next);
      if (gain1 <= 0 || b_next == a_next) continue;
      const int b = pred(b_next);
      const int b_next_offset = offset(a, b_next);
      const std::int64_t open_gain = gain1 + arc(b, b_next);
      // Close with (c, a+): c in S2's range, i.e. offset in [offset(b+), n - 1].
      const int* in_a_next = inCandidates(a_next);
      for (int j = 0; j < k; ++j) {
        const int c = in_a_next[j];
        if (offset(a, c) < b_next_offset) continue;
        const std::int64_t gain2 = open_gain - arc(c, a_next);
        if (gain2 <= 0) continue;
        const int c_next = succ(c);
        if (gain2 + arc(c, c_next) - arc(b, c_next) > 0) {
          applySegmentSwap(a, b, c, gain2 + arc(c, c_next) - arc(b, c_next));
          return true;
        }
      }
      // Close with (b, c+): c+ after b+, up to a itself (offset n).
      const int* out_b = outCandidates(b);
      for (int j = 0; j < k; ++j) {
        const int c_next = out_b[j];
        const int c_next_offset = c_next == a ? n_ : offset(a, c_next);
        if (c_next_offset <= b_next_offset) continue;
        const std::int64_t gain2 = open_gain - arc(b, c_next);
        if (gain2 <= 0) continue;
        const int c = pred(c_next);
        if (gain2 + arc(c, c_next) - arc(c, a_next) > 0) {
          applySegmentSwap(a, b, c, gain2 + arc(c, c_next) - arc(c, a_next));
          return true;
        }
      }
    }
    return false;
  }

  /// Reversals of a segment next to (a, a+): either a+..b, adding (a, b) and (a+, b+), or z..a,
  /// adding (pred z, a) and (z, a+). Reversing changes the cost of every arc inside (read from
  /// the prefix sums), so these moves pay off on nearly symmetric costs (the planner's travel
  /// times), where they are what 2-opt is to the symmetric TSP.
  bool tryReversal(int a) {
    const int a_next = succ(a);
    const std::int64_t removed_a = arc(a, a_next);
    const int k = candidates_.k;
    const int* out_a = outCandidates(a);
    for (int i = 0; i < k; ++i) {
      const int b = out_a[i];
      const std::int64_t gain1 = removed_a - arc(a, b);
      const int length = offset(a, b);  // nodes a+..b
      if (gain1 <= 0 || length < 2) continue;
      const int b_next = succ(b);
      const std::int64_t gain =
          gain1 + arc(b, b_next) - arc(a_next, b_next) - reversalChange(pos_[std::size_t(a_next)], length - 1);
      if (gain > 0) {
        applyReversal(a, length, gain);
        return true;
      }
    }
    const int* in_a_next = inCandidates(a_next);
    for (int i = 0; i < k; ++i) {
      const int z = in_a_next[i];
      const std::int64_t gain1 = removed_a - arc(z, a_next);
      const int length = offset(z, a) + 1;  // nodes z..a
      if (gain1 <= 0 || length < 2 || length > n_ - 1) continue;
      const int y = pred(z);
      const std::int64_t gain = gain1 + arc(y, z) - arc(y, a) - reversalChange(pos_[std::size_t(z)], length - 1);
      if (gain > 0) {
        applyReversal(y, length, gain);
        return true;
      }
    }
    return false;
  }

  /// Cost change of reversing the `count` consecutive arcs from tour position `start` on.
  std::int64_t reversalChange(int start, int count) {
    if (!prefix_valid_) {
      for (int p = 0; p < n_; ++p)
        reversal_prefix_[std::size_t(p) + 1] = reversal_prefix_[std::size_t(p)] + reversal_change_[std::size_t(p)];
      prefix_valid_ = true;
    }
    const int end = start + count;
    if (end <= n_) return reversal_prefix_[std::size_t(end)] - reversal_prefix_[std::size_t(start)];
    return reversal_prefix_[std::size_t(n_)] - reversal_prefix_[std::size_t(start)] +
           reversal_prefix_[std::size_t(end - n_)];
  }

  /// Reverses the `length` nodes after `before` in place.
  void applyReversal(int before, int length, std::int64_t gain) {
    const int first = pos_[std::size_t(before)] + 1;
    const int after = at(first + length);
    for (int i = 0, j = length - 1; i < j; ++i, --j) {
      const int pi = wrap(first + i), pj = wrap(first + j);
      std::swap(tour_[std::size_t(pi)], tour_[std::size_t(pj)]);
      pos_[std::size_t(tour_[std::size_t(pi)])] = pi;
      pos_[std::size_t(tour_[std::size_t(pj)])] = pj;
    }
    refreshArcs(first, length);
    cost_ -= gain;
    for (const int node : {before, at(first), at(first + length - 1), after}) activate(node);
  }

  /// Recomputes the reversal change of the arcs touching positions [start, start + length).
  void refreshArcs(int start, int length) {
    for (int i = -1; i < length && i < n_ - 1; ++i) {
      const int p = wrap(start + i);
      const int from = tour_[std::size_t(p)], to = at(p + 1);
      reversal_change_[std::size_t(p)] = arc(to, from) - arc(from, to);
    }
    prefix_valid_ = false;
  }

  /// a S1 S2 S3 -> a S2 S1 S3 (S3 ends with a). Any two of the three cyclically adjacent
  /// segments can be swapped for the same result; swapping the two shortest moves least.
  void applySegmentSwap(int a, int b, int c, std::int64_t gain) {
    const int a_next = succ(a), b_next = succ(b), c_next = succ(c);
    const int len1 = offset(a, b), len2 = offset(b, c), len3 = n_ - len1 - len2;
    const int start1 = pos_[std::size_t(a_next)], start2 = pos_[std::size_t(b_next)],
              start3 = pos_[std::size_t(c_next)];
    if (len3 >= len1 && len3 >= len2)
      swapBlocks(start1, len1, len2);
    else if (len1 >= len2)
      swapBlocks(start2, len2, len3);
    else
      swapBlocks(start3, len3, len1);
    cost_ -= gain;
    for (const int node : {a, a_next, b, b_next, c, c_next}) activate(node);
  }

  /// X Y -> Y X for the blocks X = [start, start + len_x) and Y right after it (cyclic).
  void swapBlocks(int start, int len_x, int len_y) {
    buffer_.clear();
    for (int i = 0; i < len_y; ++i) buffer_.push_back(at(start + len_x + i));
    for (int i = 0; i < len_x; ++i) buffer_.push_back(at(start + i));
    writeBack(start);
  }

  void writeBack(int start) {
    for (std::size_t i = 0; i < buffer_.size(); ++i) {
      const int p = wrap(start + int(i));
      tour_[std::size_t(p)] = buffer_[i];
      pos_[std::size_t(buffer_[i])] = p;
    }
    refreshArcs(start, int(buffer_.size()));
  }

  const int n_;
  const std::int64_t* costs_;
  const CandidateLists& candidates_;
  std::vector<int> tour_, pos_;
  std::int64_t cost_ = 0;
  // reversal_change_[p]: cost(tour[p+1], tour[p]) - cost(tour[p], tour[p+1]), kept up to date
  // at every change; its prefix sums are rebuilt lazily when a reversal is evaluated.
  std::vector<std::int64_t> reversal_change_, reversal_prefix_;
  bool prefix_valid_ = false;
  std::vector<int> queue_;  // ring buffer of active nodes (don't-look bit off)
  std::vector<char> queued_;
  int queue_head_ = 0, queue_size_ = 0;
  std::vector<int> buffer_;
};

}  // namespace

IlsOutcome iteratedLocalSearch(const AtspInstance& instance, const CandidateLists& candidates,
                               const std::vector<int>& initial, const IlsSettings& settings, const Deadline& deadline) {
  TourSearch search(instance, candidates);
  Random random(settings.seed);
  IlsOutcome outcome;
  search.setTour(initial);
  search.descend(deadline);
  outcome.order = search.order();
  outcome.cost = search.cost();
  outcome.time_to_best_s = deadline.elapsedS();
  const int max_rejections = std::max(1, instance.n / kRejectionsPerWalkStepDivisor);
  int rejections = 0;
  TourSearch::Snapshot before_kick;
  std::uint64_t best_round = 0;
  while (true) {
    if (settings.lower_bound && outcome.cost <= *settings.lower_bound) {
      outcome.reached_bound = true;
      break;
    }
    if (settings.max_iterations != 0 && outcome.iterations >= settings.max_iterations) {
      outcome.reached_max_iterations = true;
      break;
    }
    if (settings.max_stale_iterations != 0 && outcome.iterations - best_round >= settings.max_stale_iterations) {
      outcome.settled = true;
      break;
    }
    if (deadline.passed()) break;
    search.save(before_kick);
    search.kick(random);
    search.descend(deadline);
    ++outcome.iterations;
    if (search.cost() < outcome.cost) {
      outcome.order = search.order();
      outcome.cost = search.cost();
      outcome.time_to_best_s = deadline.elapsedS();
      best_round = outcome.iterations;
      rejections = 0;
    } else if (search.cost() > before_kick.cost) {
      if (++rejections < max_rejections)
        search.restore(before_kick);
      else
        rejections = 0;  // a random-walk step out of a basin that kicks keep falling back into
    }
#ifdef ATSP_DEBUG
    if (search.cost() != closedTourCost(instance, search.order())) std::abort();
#endif
  }
  return outcome;
}

}  // namespace vdbmap::planner::atsp
