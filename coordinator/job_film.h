// One job's image as it is merged: the whole-image film of exact sums, which units it contains,
// the progress figures derived from them (kept up to date on each merge, never recounted), its
// error estimate and its checkpoint file.
//
// A job with a target error decides at 4, 8, 16, ... passes and at its cap whether to stop
// (error_estimate.h), from the merged film only. Until the decision at D passes is taken, only
// units of passes below D may be leased and merged (leaseLimit(), which the LeaseScheduler
// enforces), so the film it is taken from holds exactly passes [0, D): the decision, and so the
// stopping pass and the image, are the same for any number of workers, any order of results
// and any coordinator restart.
//
// An adaptive job (JobSettings.adaptive) decides per tile of the fixed adaptive grid
// (decideTiles): a finished tile's units of later passes are marked merged without a result
// (skipped; takeSkippedUnits() hands them to the LeaseScheduler), and the decisions taken are
// written beside the checkpoint (CHECKPOINT.decisions) before any unit past the decision point is
// leased, so a restarted coordinator knows which tiles finished: the film alone cannot tell
// (skipped and merged units look alike, and the film has moved on). Not thread-safe: the caller
// serializes calls, except writeFile() and readFile(), which do the file I/O outside the caller's
// lock (serialized per job by writeMutex()).
#pragma once

#include "alphorn/v1/farm.pb.h"
#include "common/farm/job_grid.h"
#include "common/farm/metrics.h"
#include "common/render/error_estimate.h"
#include "common/render/film.h"
#include "coordinator/checkpoint.h"

#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace alphorn::coordinator {

class JobFilm {
  public:
    JobFilm() = default;
    // `targetError`: the job stops at the first decision point whose estimate reaches it.
    // `adaptive` (with a target): tile-adaptive passes; the grid's tiles must each lie in one
    // tile of the adaptive grid.
    // `checkpointOwner` is written into its checkpoints, and a checkpoint of another owner is
    // not read back (see writeCheckpoint).
    JobFilm(const farm::JobGrid& grid, std::string checkpointPath, std::string checkpointOwner = "",
            std::optional<double> targetError = std::nullopt, bool adaptive = false);
    JobFilm(JobFilm&&) = delete;

    // Memory a running job's film and merged flags take.
    static uint64_t memoryBytes(int width, int height, uint64_t unitCount,
                                SmallerRadius smallerRadius = SmallerRadius::None);

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
    // Every unit merged, or the target error reached at a decision point.
    bool complete() const { return m_mergedCount == m_grid.unitCount() || m_targetReached; }
    bool targetReached() const { return m_targetReached; }
    // Units [0, leaseLimit()) may be leased and merged: all of them, or for a job with a target
    // error those of the passes before the next decision point.
    uint32_t leaseLimit() const;
    // The estimate at the last decision point (see JobStatus.error_estimate).
    const std::optional<ErrorEstimate>& estimate() const { return m_estimate; }
    const std::optional<double>& targetError() const { return m_targetError; }
    bool adaptive() const { return m_adaptive; }
    uint32_t adaptiveTiles() const { return static_cast<uint32_t>(m_adaptiveTiles.size()); }
    uint32_t adaptiveTilesFinished() const { return m_finishedCount; }
    // Units skipped (marked merged without a result) since the last call, for
    // LeaseScheduler::skipUnits.
    std::vector<uint32_t> takeSkippedUnits() { return std::exchange(m_newlySkipped, {}); }
    // The passes the job is expected to end with: all of them, or for a job with a target error
    // the decision point at or after the projected passes (the cap without an estimate yet).
    uint32_t expectedPasses() const;
    uint32_t passesComplete() const { return m_passesComplete; }
    uint64_t samplesMerged() const { return m_samplesMerged; }
    uint64_t invalidSamples() const { return m_film.invalidSamples; }

    // Checkpoints. A copy is taken under the caller's lock, written without it.
    struct Copy {
        FilmBlock film;
        std::vector<bool> merged;
        uint32_t count = 0;
        uint64_t generation = 0;  // generation() when the copy was taken
    };
    Copy copy() const { return Copy{m_film, m_merged, m_mergedCount, m_generation}; }
    // Counts the times the film was emptied (startEmpty, forget): a checkpoint copied before
    // such a reset must not be written after it.
    uint64_t generation() const { return m_generation; }
    // Merged units not in the checkpoint yet?
    bool dirty() const { return m_mergedCount > m_checkpointedCount; }
    // Merged units the checkpoint on disk does not hold.
    uint32_t unsavedCount() const { return m_mergedCount - m_checkpointedCount; }
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
    // Marks the unit merged and counts it; returns its samples (tile pixels x passes, none for
    // a skipped unit).
    uint64_t countMerged(uint32_t unitIndex);
    // An adaptive job's unit of a finished tile at or after the pass the tile finished.
    bool skipped(uint32_t unitIndex) const;
    // Marks the units of tiles finished at `passes` that are not merged yet as skipped.
    void skipFinishedUnits();
    void writeDecisions();
    void readDecisions();
    std::string decisionsPath() const { return m_path + ".decisions"; }
    void resetState();
    // Adds the estimate just made to the history and gives it the measured slope.
    void recordEstimate();
    // At a decision point: the estimate, and whether the target stops the job.
    void decide(const FilmBlock& film);

    farm::JobGrid m_grid;
    std::string m_path;
    std::string m_owner;
    FilmBlock m_film;  // whole image while running; released when the job ends
    std::vector<bool> m_merged;
    std::vector<uint32_t> m_mergedPerChunk;
    uint32_t m_mergedCount = 0, m_passesComplete = 0;
    uint64_t m_samplesMerged = 0;
    uint32_t m_checkpointedCount = 0, m_checkpointsWritten = 0;
    uint64_t m_generation = 0;
    std::optional<double> m_targetError;
    uint32_t m_decisionPasses = 0;  // the next decision point
    std::optional<ErrorEstimate> m_estimate;
    std::vector<ErrorEstimate> m_history;  // estimates at the decision points (for the slope)
    bool m_targetReached = false;
    bool m_adaptive = false;
    std::vector<Tile> m_adaptiveTiles;
    std::vector<uint32_t> m_adaptiveTileOf;  // per tile of the job's grid
    std::vector<uint32_t> m_finishedAt;      // per adaptive tile: the pass it finished at, or 0
    uint32_t m_finishedCount = 0;
    uint32_t m_lastDecisionTaken = 0;  // an adaptive job's last decision point that went on
    std::vector<uint32_t> m_newlySkipped;
    std::string m_checkpointError;
    std::mutex m_writeMutex;
};

// The job's target error, if it has one.
std::optional<double> targetError(const v1::JobSettings& settings);
// Fills the status's error estimate, projected passes and target_reached from the film.
void describeEstimate(const JobFilm& film, v1::JobStatus& status);

}  // namespace alphorn::coordinator
