#pragma once
// A progress bar for long work (training, inverting a clip): drawn on standard error only when it is a
// terminal, so logs, pipes and tests stay quiet. Redrawn at most every 100 ms; finish() clears it.

#include <chrono>
#include <string>

namespace rig::app {

class ProgressBar {
public:
    // `label` starts the line ("learning", "inverting").
    explicit ProgressBar(std::string label);
    ~ProgressBar();
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    // `fraction` in [0, 1]; `stage` says what is being done now (may be empty).
    void update(double fraction, const std::string& stage = {});
    // Clears the line (also done by the destructor).
    void finish();

private:
    std::string label_;
    bool enabled_ = false;
    bool drawn_ = false;
    std::chrono::steady_clock::time_point start_;
    std::chrono::steady_clock::time_point last_;
};

}  // namespace rig::app
