#pragma once
// A free list of scratch objects: solves on many threads each take one and give it back, so that a steady
// stream of solves allocates nothing (the solver's workspaces, plans' graphs and per-solve scratch).

#include <memory>
#include <mutex>
#include <utility>
#include <vector>

namespace rig {

template <class T>
class Pool {
public:
    // One item from the free list, or make() when it is empty.
    template <class Make>
    std::unique_ptr<T> acquire(Make&& make)
    {
        {
            std::lock_guard lock(mutex_);
            if (!free_.empty()) {
                std::unique_ptr<T> item = std::move(free_.back());
                free_.pop_back();
                return item;
            }
        }
        return make();
    }
    void release(std::unique_ptr<T> item)
    {
        std::lock_guard lock(mutex_);
        free_.push_back(std::move(item));
    }

private:
    std::mutex mutex_;
    std::vector<std::unique_ptr<T>> free_;
};

// Returns the item to its pool on every way out of a scope.
template <class T>
class Borrowed {
public:
    template <class Make>
    Borrowed(Pool<T>& pool, Make&& make) : pool_(pool), item_(pool.acquire(std::forward<Make>(make)))
    {
    }
    ~Borrowed() { pool_.release(std::move(item_)); }
    Borrowed(const Borrowed&) = delete;
    Borrowed& operator=(const Borrowed&) = delete;
    T& operator*() const { return *item_; }
    T* operator->() const { return item_.get(); }

private:
    Pool<T>& pool_;
    std::unique_ptr<T> item_;
};

}  // namespace rig
