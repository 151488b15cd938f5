// One job's image as it is merged: the whole-image film of exact sums, which units it contains,
// the progress figures derived from them (kept up to date on each merge, never recounted), and
// its checkpoint file. Not thread-safe: the caller serializes calls, except writeFile() and
// readFile(), which do the file I/O outside the caller's lock (serialized per job by
// writeMutex()).
#pragma once

#include "common/farm/job_grid.h"
#include "common/farm/metrics.h"
#include "common/render/film.h"
#include "coordinator/checkpoint.h"

#include <mutex>
#include <string>
#include <vector>

namespace alphorn::coordinator {

class JobFilm {
  public:
    JobFilm() = default;
    JobFilm(const farm::JobGrid& grid, std::string checkpointPath);
    JobFilm(JobFilm&&) = delete;

    // Memory a running job's film and merged flags take.
    static uint64_t memoryBytes(int width, int height, uint64_t unitCount);

    // Starts with nothing merged and a zero film in memory.
    void startEmpty();
    // Starts from a checkpoint (already read); keeps its film in memory when `keepFilm`.
    void restore(Checkpoint checkpoint, bool keepFilm);
    // Adds a unit's result. The caller merges each unit at most once (LeaseScheduler).
    void merge(uint32_t unitIndex, const FilmBlock& block);
    // Frees the film (an ended job's image is served from its checkpoint).
    void release() { m_film = FilmBlock(); }
    // Forgets everything merged (a job whose checkpoint was lost is rendered again).
    void forget();

    bool inMemory() const { return m_film.width() > 0; }
    const FilmBlock& film() const { return m_film; }
    const std::vector<bool>& merged() const { return m_merged; }
    uint32_t mergedCount() const { return m_mergedCount; }
    bool complete() const { return m_mergedCount == m_grid.unitCount(); }
    uint32_t passesComplete() const { return m_passesComplete; }
    uint64_t samplesMerged() const { return m_samplesMerged; }
    uint64_t invalidSamples() const { return m_film.invalidSamples; }

    // Checkpoints. A copy is taken under the caller's lock, written without it.
    struct Copy {
        FilmBlock film;
        std::vector<bool> merged;
        uint32_t count = 0;
    };
    Copy copy() const { return Copy{m_film, m_merged, m_mergedCount}; }
    // Merged units not in the checkpoint yet?
    bool dirty() const { return m_mergedCount > m_checkpointedCount; }
    // Would a copy of `count` merged units be newer than the checkpoint on disk? Merges only
    // add units, so a higher count is a newer film; a newer one is never overwritten.
    bool newerThanCheckpoint(uint32_t count) const {
        return count > m_checkpointedCount || (count == 0 && m_checkpointedCount == 0);
    }
    std::mutex& writeMutex() { return m_writeMutex; }
    void writeFile(const Copy& copy) const;
    Checkpoint readFile() const;
    void checkpointWritten(uint32_t count);
    void checkpointFailed(const std::string& error) {
        m_checkpointError = error;
        farm::CoordinatorMetrics::checkpointFailed();
    }
    void clearCheckpointError() { m_checkpointError.clear(); }
    // The last failed write (e.g. a full disk); cleared by the next success.
    const std::string& checkpointError() const { return m_checkpointError; }
    uint32_t checkpointsWritten() const { return m_checkpointsWritten; }

  private:
    // Marks the unit merged and counts it; returns its samples (tile pixels x passes).
    uint64_t countMerged(uint32_t unitIndex);

    farm::JobGrid m_grid;
    std::string m_path;
    FilmBlock m_film;  // whole image while running; released when the job ends
    std::vector<bool> m_merged;
    std::vector<uint32_t> m_mergedPerChunk;
    uint32_t m_mergedCount = 0, m_passesComplete = 0;
    uint64_t m_samplesMerged = 0;
    uint32_t m_checkpointedCount = 0, m_checkpointsWritten = 0;
    std::string m_checkpointError;
    std::mutex m_writeMutex;
};

}  // namespace alphorn::coordinator
