#include "coordinator/job_film.h"

#include "common/core/error.h"
#include "common/farm/metrics.h"

#include <absl/strings/str_format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace alphorn::coordinator {

JobFilm::JobFilm(const farm::JobGrid& grid, std::string checkpointPath, std::string checkpointOwner,
                 std::optional<double> targetError, bool adaptive)
    : m_grid(grid),
      m_path(std::move(checkpointPath)),
      m_owner(std::move(checkpointOwner)),
      m_merged(grid.unitCount(), false),
      m_mergedPerChunk(grid.chunkCount(), 0),
      m_targetError(targetError),
      m_decisionPasses(nextDecisionPasses(0, grid.passes())),
      m_adaptive(adaptive && targetError) {
    if (m_adaptive) {
        m_adaptiveTiles = alphorn::adaptiveTiles(grid.width(), grid.height());
        const int columns = (grid.width() + kAdaptiveTileSize - 1) / kAdaptiveTileSize;
        for (uint32_t t = 0; t < grid.tileCount(); ++t) {
            const Tile tile = grid.unit(t).tile;
            const int column = tile.x0 / kAdaptiveTileSize, row = tile.y0 / kAdaptiveTileSize;
            if ((tile.x1 - 1) / kAdaptiveTileSize != column ||
                (tile.y1 - 1) / kAdaptiveTileSize != row)
                fail("an adaptive job needs tiles within the %d-pixel adaptive grid",
                     kAdaptiveTileSize);
            m_adaptiveTileOf.push_back(static_cast<uint32_t>(row * columns + column));
        }
        m_finishedAt.assign(m_adaptiveTiles.size(), 0);
    }
    // Admission gives a target-error job chunks that end at every decision point.
    if (m_targetError && m_grid.passes() > 0) {
        for (uint32_t d = m_decisionPasses; d < m_grid.passes();
             d = nextDecisionPasses(d, m_grid.passes()))
            if (d % m_grid.passesPerUnit() != 0)
                fail(
                    "a job with a target error needs pass chunks ending at %u passes, and has %u "
                    "passes per unit",
                    d, m_grid.passesPerUnit());
    }
}

uint32_t JobFilm::leaseLimit() const {
    if (!m_targetError || m_targetReached || m_decisionPasses >= m_grid.passes())
        return m_targetReached ? 0 : m_grid.unitCount();
    return m_decisionPasses / m_grid.passesPerUnit() * m_grid.tileCount();
}

uint32_t JobFilm::expectedPasses() const {
    if (!m_targetError || !m_estimate) return m_grid.passes();
    if (m_targetReached) return m_estimate->passes;
    const double projected = projectedPasses(*m_estimate, *m_targetError);
    uint32_t passes = m_decisionPasses;
    while (passes < m_grid.passes() && double(passes) < projected)
        passes = nextDecisionPasses(passes, m_grid.passes());
    return passes;
}

void JobFilm::decide(const FilmBlock& film) {
    const uint32_t passes = m_decisionPasses;
    if (m_adaptive) {
        std::vector<bool> finishedBefore(m_adaptiveTiles.size());
        for (size_t t = 0; t < m_adaptiveTiles.size(); ++t) finishedBefore[t] = m_finishedAt[t] > 0;
        const TileDecisions decisions =
            decideTiles(film, m_adaptiveTiles, finishedBefore, passes, *m_targetError);
        m_estimate = decisions.image;
        recordEstimate();
        if (passes >= m_grid.passes()) return;
        const uint32_t finished = static_cast<uint32_t>(
            std::count(decisions.finished.begin(), decisions.finished.end(), true));
        if (finished == m_adaptiveTiles.size()) {
            m_finishedCount = finished;
            m_targetReached = true;
            return;
        }
        for (size_t t = 0; t < m_adaptiveTiles.size(); ++t)
            if (decisions.finished[t] && m_finishedAt[t] == 0) m_finishedAt[t] = passes;
        m_finishedCount = finished;
        m_lastDecisionTaken = passes;
        // Written before any unit past this point is leased: a restart sees every decision
        // that had an effect.
        writeDecisions();
        skipFinishedUnits();
        m_decisionPasses = nextDecisionPasses(passes, m_grid.passes());
        return;
    }
    m_estimate = estimateError(film, Tile{0, 0, m_grid.width(), m_grid.height()}, passes);
    recordEstimate();
    if (passes >= m_grid.passes()) return;
    if (m_targetError && reachesTarget(m_estimate, *m_targetError)) {
        m_targetReached = true;
        return;
    }
    m_decisionPasses = nextDecisionPasses(passes, m_grid.passes());
}

void JobFilm::recordEstimate() {
    if (!m_estimate) return;
    // After a restart the history starts at the decision taken again: the slope (only for the
    // projection shown, never for a decision) is then unknown until the next point.
    if (m_history.empty() || m_history.back().passes < m_estimate->passes)
        m_history.push_back(*m_estimate);
    m_estimate->slope = fitSlope(m_history);
}

bool JobFilm::skipped(uint32_t unitIndex) const {
    if (!m_adaptive) return false;
    const RenderUnit unit = m_grid.unit(unitIndex);
    const uint32_t finishedAt = m_finishedAt[m_adaptiveTileOf[unitIndex % m_grid.tileCount()]];
    return finishedAt > 0 && unit.passBegin >= finishedAt;
}

void JobFilm::skipFinishedUnits() {
    // Only units at or after the decision point can be skipped: they lie past the barrier, so
    // none is merged or leased (those of earlier decisions are marked already).
    for (uint32_t chunk = m_decisionPasses / m_grid.passesPerUnit(); chunk < m_grid.chunkCount();
         ++chunk)
        for (uint32_t t = 0; t < m_grid.tileCount(); ++t) {
            const uint32_t index = chunk * m_grid.tileCount() + t;
            if (!m_merged[index] && skipped(index)) {
                countMerged(index);
                m_newlySkipped.push_back(index);
            }
        }
}

void JobFilm::writeDecisions() {
    if (m_path.empty()) return;
    // One line per finished tile: its index and the pass it finished at; the first line is the
    // last decision point that went on.
    std::string text =
        absl::StrFormat("alphorn adaptive decisions 1\nlast %u\n", m_lastDecisionTaken);
    for (size_t t = 0; t < m_finishedAt.size(); ++t)
        if (m_finishedAt[t] > 0) text += absl::StrFormat("%u %u\n", t, m_finishedAt[t]);
    const std::string temporary = decisionsPath() + ".tmp";
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        out << text;
        out.flush();
        if (!out) {
            // Not thrown: the merge that led here is done. The job goes on, and shows the error
            // as it shows a failed checkpoint; only a restart before the next successful write
            // would lose the decision.
            checkpointFailed("cannot write " + temporary);
            return;
        }
    }
    std::error_code error;
    std::filesystem::rename(temporary, decisionsPath(), error);
    if (error) checkpointFailed("cannot write " + decisionsPath() + ": " + error.message());
}

void JobFilm::readDecisions() {
    std::ifstream in(decisionsPath());
    if (!in) return;  // no decision went on yet
    std::string header;
    std::getline(in, header);
    std::string word;
    uint32_t last = 0;
    if (header != "alphorn adaptive decisions 1" || !(in >> word >> last) || word != "last")
        fail("%s: not a decisions file of this Alphorn", decisionsPath());
    uint32_t tile = 0, passes = 0;
    while (in >> tile >> passes) {
        if (tile >= m_finishedAt.size() || passes == 0 || passes > last)
            fail("%s: tile %u finished at %u passes is not possible", decisionsPath(), tile,
                 passes);
        m_finishedAt[tile] = passes;
    }
    if (!in.eof()) fail("%s: unreadable line", decisionsPath());
    m_lastDecisionTaken = last;
    m_finishedCount = static_cast<uint32_t>(
        std::count_if(m_finishedAt.begin(), m_finishedAt.end(), [](uint32_t p) { return p > 0; }));
}

uint64_t JobFilm::memoryBytes(int width, int height, uint64_t unitCount,
                              SmallerRadius smallerRadius) {
    // Per unit a merged flag (a bit, counted as a byte); per chunk a counter (fewer than units).
    return uint64_t(width) * uint64_t(height) *
               FilmBlock(0, 0, 0, 0, PassHalves::Kept, smallerRadius).bytesPerPixel() +
           unitCount;
}

void JobFilm::startEmpty() {
    forget();
    m_film = FilmBlock(0, 0, m_grid.width(), m_grid.height(), PassHalves::Kept,
                       m_grid.tiles().smallerRadius());
}

void JobFilm::forget() {
    resetState();
    if (m_adaptive && !m_path.empty()) {
        std::error_code ignored;
        std::filesystem::remove(decisionsPath(), ignored);
    }
}

void JobFilm::resetState() {
    ++m_generation;
    m_merged.assign(m_grid.unitCount(), false);
    m_mergedPerChunk.assign(m_grid.chunkCount(), 0);
    m_mergedCount = m_passesComplete = 0;
    m_samplesMerged = 0;
    m_checkpointedCount = 0;
    m_film = FilmBlock();
    m_decisionPasses = nextDecisionPasses(0, m_grid.passes());
    m_estimate.reset();
    m_history.clear();
    m_targetReached = false;
    m_finishedAt.assign(m_adaptiveTiles.size(), 0);
    m_finishedCount = 0;
    m_lastDecisionTaken = 0;
    m_newlySkipped.clear();
}

void JobFilm::restore(Checkpoint checkpoint, bool keepFilm) {
    const bool jobKeepsSmallerRadius = m_grid.tiles().smallerRadius() == SmallerRadius::Kept;
    if (checkpoint.film.width() > 0 &&
        checkpoint.film.keepsSmallerRadius() != jobKeepsSmallerRadius)
        fail("%s: the checkpoint's film %s the smaller radius's image, the job's %s", m_path,
             checkpoint.film.keepsSmallerRadius() ? "keeps" : "does not keep",
             jobKeepsSmallerRadius ? "does" : "does not");
    resetState();
    if (m_adaptive) {
        // The decisions file, not the merged flags, tells which tiles finished (a skipped unit
        // is flagged merged too); the checkpoint may be older than the last decision.
        readDecisions();
        for (uint32_t i = 0; i < m_grid.unitCount(); ++i)
            if (checkpoint.merged.at(i) || skipped(i)) countMerged(i);
        m_checkpointedCount = m_mergedCount;
        if (m_lastDecisionTaken > 0)
            m_decisionPasses = nextDecisionPasses(m_lastDecisionTaken, m_grid.passes());
        if (m_passesComplete >= m_decisionPasses && m_passesComplete > 0) decide(checkpoint.film);
        // The scheduler is given the merged flags, skipped units included.
        m_newlySkipped.clear();
        if (keepFilm) m_film = std::move(checkpoint.film);
        return;
    }
    uint32_t lastPassMerged = 0;
    for (uint32_t i = 0; i < m_grid.unitCount(); ++i)
        if (checkpoint.merged.at(i)) {
            countMerged(i);
            lastPassMerged = std::max(lastPassMerged, m_grid.unit(i).passEnd);
        }
    m_checkpointedCount = m_mergedCount;
    // Units past a decision point were merged only after it decided to go on; the decision at
    // the first point not passed yet is taken again from the same film (the same answer).
    while (m_decisionPasses < m_grid.passes() && lastPassMerged > m_decisionPasses)
        m_decisionPasses = nextDecisionPasses(m_decisionPasses, m_grid.passes());
    if (m_passesComplete >= m_decisionPasses && m_passesComplete > 0) decide(checkpoint.film);
    if (keepFilm) m_film = std::move(checkpoint.film);
}

uint64_t JobFilm::countMerged(uint32_t unitIndex) {
    m_merged[unitIndex] = true;
    ++m_mergedCount;
    const RenderUnit unit = m_grid.unit(unitIndex);
    const uint64_t samples = skipped(unitIndex) ? 0
                                                : uint64_t(unit.tile.width()) * unit.tile.height() *
                                                      (unit.passEnd - unit.passBegin);
    m_samplesMerged += samples;
    const uint32_t chunk = m_grid.chunkOf(unitIndex);
    if (++m_mergedPerChunk[chunk] == m_grid.tileCount())
        m_passesComplete += m_grid.chunkPasses(chunk);
    return samples;
}

void JobFilm::merge(uint32_t unitIndex, const FilmBlock& block) {
    if (m_merged.at(unitIndex)) fail("unit %u is merged already", unitIndex);
    if (unitIndex >= leaseLimit())
        fail("unit %u is beyond the decision at %u passes", unitIndex, m_decisionPasses);
    m_film.add(block);
    farm::CoordinatorMetrics::unitMerged(countMerged(unitIndex));
    // Without a target, later passes may be merged already: the estimate is then approximate
    // (it is exact once the job is complete, at its last decision point).
    while (!m_targetReached && m_passesComplete >= m_decisionPasses &&
           m_decisionPasses <= m_grid.passes()) {
        const uint32_t before = m_decisionPasses;
        decide(m_film);
        if (m_decisionPasses == before) break;
    }
}

void JobFilm::writeFile(const Copy& copy) const {
    writeCheckpoint(m_path, m_owner, copy.film, copy.merged);
}

Checkpoint JobFilm::readFile() const {
    return readCheckpoint(m_path, m_owner, m_grid.width(), m_grid.height(), m_grid.unitCount());
}

void JobFilm::checkpointWritten(uint32_t count) {
    m_checkpointError.clear();
    m_checkpointedCount = count;
    ++m_checkpointsWritten;
}

std::optional<double> targetError(const v1::JobSettings& settings) {
    if (!settings.has_target_error()) return std::nullopt;
    return settings.target_error();
}

void describeEstimate(const JobFilm& film, v1::JobStatus& status) {
    status.set_target_reached(film.targetReached());
    const std::optional<ErrorEstimate>& estimate = film.estimate();
    if (!estimate) return;
    status.set_error_estimate(estimate->relativeRmse);
    status.set_error_estimate_passes(estimate->passes);
    if (estimate->relativeBias) status.set_error_bias(*estimate->relativeBias);
    if (film.targetError())
        status.set_projected_passes(projectedPasses(*estimate, *film.targetError()));
    if (film.adaptive()) {
        status.set_adaptive_tiles(film.adaptiveTiles());
        status.set_adaptive_tiles_finished(film.adaptiveTilesFinished());
    }
}

}  // namespace alphorn::coordinator
