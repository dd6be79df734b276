#pragma once
// SharedVector<T>: a std::vector<T> with value semantics whose copies share one buffer until one
// of them is written (copy-on-write).
//
// Why: a keyframe's features (keypoints, descriptors, bearings, its keypoint grid, BoW vector and
// direct index) never change after the keyframe is made, but the map is copied whole for the
// loop-closing stage after every keyframe (docs/slam.md, "Threads"), so that copy was linear in
// the bytes of every keyframe's features: ~0.1 ms per keyframe, 13 ms per copy for the 209
// keyframes of a 1000-frame run, on the map's one writer. Shared, a keyframe's copy is its
// landmark links and graph edges.
//
// Reading is std::vector's const interface (and a conversion to const std::vector<T>&, so that
// functions taking one accept it). Writing is explicit: assignment from a vector, push_back,
// mutate(), which first detaches the buffer when it is shared, or overwrite(). There is
// no non-const operator[] or begin(): a loop over a keyframe that is not const must not copy the
// buffer behind the reader's back.
//
// Thread safety: like a std::vector value. Copies held by other threads are never written
// through (a write detaches first), so a writer and readers of different copies need no lock.

#include <cstddef>
#include <initializer_list>
#include <memory>
#include <utility>
#include <vector>

namespace lcv::slam {

template <typename T>
class SharedVector {
 public:
  using value_type = T;
  using size_type = std::size_t;
  using const_iterator = typename std::vector<T>::const_iterator;
  using const_reference = const T&;

  SharedVector() = default;
  SharedVector(std::vector<T> values)  // NOLINT(google-explicit-constructor): a vector is one
      : data_(values.empty() ? nullptr : std::make_shared<std::vector<T>>(std::move(values))) {}
  SharedVector(std::initializer_list<T> values) : SharedVector(std::vector<T>(values)) {}

  SharedVector& operator=(std::vector<T> values) {
    *this = SharedVector(std::move(values));
    return *this;
  }

  const std::vector<T>& get() const { return data_ ? *data_ : Empty(); }
  operator const std::vector<T>&() const { return get(); }  // NOLINT(google-explicit-constructor)

  size_type size() const { return data_ ? data_->size() : 0; }
  bool empty() const { return size() == 0; }
  const T& operator[](size_type i) const { return (*data_)[i]; }
  const T& at(size_type i) const { return get().at(i); }
  const T& front() const { return data_->front(); }
  const T& back() const { return data_->back(); }
  const T* data() const { return data_ ? data_->data() : nullptr; }
  const_iterator begin() const { return get().begin(); }
  const_iterator end() const { return get().end(); }

  // The buffer for writing, detached from other copies first when shared.
  std::vector<T>& mutate() {
    if (!data_) {
      data_ = std::make_shared<std::vector<T>>();
    } else if (data_.use_count() > 1) {
      data_ = std::make_shared<std::vector<T>>(*data_);
    }
    return *data_;
  }
  // The buffer for writing anew: the caller overwrites or resizes all of it. Not copied when
  // shared (a fresh one is started), and its capacity is kept when not (a frame's grid rebuilt
  // every frame allocates nothing).
  std::vector<T>& overwrite() {
    if (!data_ || data_.use_count() > 1) data_ = std::make_shared<std::vector<T>>();
    return *data_;
  }
  void push_back(const T& value) { mutate().push_back(value); }
  void push_back(T&& value) { mutate().push_back(std::move(value)); }
  void clear() { data_.reset(); }

  // True when this and other read the same buffer (tests, and the copy's cost).
  bool SharesBufferWith(const SharedVector& other) const {
    return data_ != nullptr && data_ == other.data_;
  }

  friend bool operator==(const SharedVector& a, const SharedVector& b) {
    return a.get() == b.get();
  }

 private:
  static const std::vector<T>& Empty() {
    static const std::vector<T> empty;
    return empty;
  }

  std::shared_ptr<std::vector<T>> data_;
};

}  // namespace lcv::slam
