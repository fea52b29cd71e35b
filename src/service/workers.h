// SPDX-License-Identifier: MIT
// The service's workers: how many requests compute at once, in which order, and the buffers
// they compute into (docs/service.md, "Inside").
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::service
{

// The workers: at most `count` requests compute at once, the others wait in arrival order (a
// plain semaphore lets late arrivals overtake, which turned 32 clients' p99 into seconds).
class WorkerQueue
{
public:
    explicit WorkerQueue(int count) : free_(count) {}

    // True once a worker is ours; false when none came within \p wait. \p first: ahead of
    // every waiting request (one that gave its worker back while it waited on the disk).
    bool acquire(std::chrono::milliseconds wait, bool first = false)
    {
        std::unique_lock lock(mutex_);
        if (free_ > 0 && waiting_.empty())
        {
            --free_;
            return true;
        }
        Waiter me;
        if (first)
        {
            waiting_.push_front(&me);
        }
        else
        {
            waiting_.push_back(&me);
        }
        if (me.ready.wait_for(lock, wait, [&] { return me.granted; }))
        {
            return true;
        }
        waiting_.erase(std::find(waiting_.begin(), waiting_.end(), &me));
        return false;
    }

    void release()
    {
        const std::lock_guard lock(mutex_);
        if (waiting_.empty())
        {
            ++free_;
            return;
        }
        Waiter* next = waiting_.front();  // handed over: the worker never becomes free meanwhile
        waiting_.pop_front();
        next->granted = true;
        next->ready.notify_one();
    }

private:
    struct Waiter
    {
        std::condition_variable ready;
        bool granted = false;
    };
    std::mutex mutex_;
    int free_;
    std::deque<Waiter*> waiting_;
};

// A worker, held while a request computes; none within the queue timeout: busy.
class WorkerSlot
{
public:
    WorkerSlot(WorkerQueue& queue, std::chrono::milliseconds wait)
        : queue_(queue), held_(queue.acquire(wait))
    {
    }
    ~WorkerSlot()
    {
        if (held_)
        {
            queue_.release();
        }
    }
    WorkerSlot(const WorkerSlot&) = delete;
    WorkerSlot& operator=(const WorkerSlot&) = delete;
    [[nodiscard]] bool held() const noexcept { return held_; }

    // The worker lent to the next request while this one waits on the disk (a commit's
    // fsync), then taken back ahead of the queue: the cores stay busy meanwhile.
    template <class Wait>
    auto lend_while(Wait&& wait)
    {
        queue_.release();
        held_ = false;
        struct Back
        {
            WorkerSlot& slot;
            ~Back() { slot.held_ = slot.queue_.acquire(std::chrono::hours(24), true); }
        } back{*this};
        return wait();
    }

private:
    WorkerQueue& queue_;
    bool held_;
};

// The positions of the copies being made, one set per request computing (so at most about
// `workers` of them), reused: not one per connection thread, which would hold a copy's
// positions for each of the 64 connections.
class BufferPool
{
public:
    class Lease
    {
    public:
        explicit Lease(BufferPool& pool) : pool_(pool), buffer_(pool.take()) {}
        ~Lease() { pool_.give(std::move(buffer_)); }
        Lease(const Lease&) = delete;
        Lease& operator=(const Lease&) = delete;
        std::vector<Positions>& operator*() const { return *buffer_; }

    private:
        BufferPool& pool_;
        std::unique_ptr<std::vector<Positions>> buffer_;
    };

private:
    std::unique_ptr<std::vector<Positions>> take()
    {
        const std::lock_guard lock(mutex_);
        if (free_.empty())
        {
            return std::make_unique<std::vector<Positions>>();
        }
        auto buffer = std::move(free_.back());
        free_.pop_back();
        return buffer;
    }
    void give(std::unique_ptr<std::vector<Positions>> buffer)
    {
        const std::lock_guard lock(mutex_);
        free_.push_back(std::move(buffer));
    }
    std::mutex mutex_;
    std::vector<std::unique_ptr<std::vector<Positions>>> free_;
};

// Counts a request in flight for as long as it lives.
class InFlight
{
public:
    explicit InFlight(std::atomic<std::int64_t>& count) : count_(count) { ++count_; }
    ~InFlight() { --count_; }
    InFlight(const InFlight&) = delete;
    InFlight& operator=(const InFlight&) = delete;

private:
    std::atomic<std::int64_t>& count_;
};

}  // namespace meshmark::service
