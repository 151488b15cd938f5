#include "coordinator/job_film.h"

#include "common/core/error.h"
#include "common/farm/metrics.h"

#include <algorithm>

namespace alphorn::coordinator {

JobFilm::JobFilm(const farm::JobGrid& grid, std::string checkpointPath,
                 std::optional<double> targetError)
    : m_grid(grid),
      m_path(std::move(checkpointPath)),
      m_merged(grid.unitCount(), false),
      m_mergedPerChunk(grid.chunkCount(), 0),
      m_targetError(targetError),
      m_decisionPasses(nextDecisionPasses(0, grid.passes())) {
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
    m_estimate = estimateError(film, Tile{0, 0, m_grid.width(), m_grid.height()}, passes);
    if (passes >= m_grid.passes()) return;
    if (m_targetError && reachesTarget(m_estimate, *m_targetError)) {
        m_targetReached = true;
        return;
    }
    m_decisionPasses = nextDecisionPasses(passes, m_grid.passes());
}

uint64_t JobFilm::memoryBytes(int width, int height, uint64_t unitCount) {
    // Per unit a merged flag (a bit, counted as a byte); per chunk a counter (fewer than units).
    return uint64_t(width) * uint64_t(height) * FilmBlock(0, 0, 0, 0).bytesPerPixel() + unitCount;
}

void JobFilm::startEmpty() {
    forget();
    m_film = FilmBlock(0, 0, m_grid.width(), m_grid.height());
}

void JobFilm::forget() {
    m_merged.assign(m_grid.unitCount(), false);
    m_mergedPerChunk.assign(m_grid.chunkCount(), 0);
    m_mergedCount = m_passesComplete = 0;
    m_samplesMerged = 0;
    m_checkpointedCount = 0;
    m_film = FilmBlock();
    m_decisionPasses = nextDecisionPasses(0, m_grid.passes());
    m_estimate.reset();
    m_targetReached = false;
}

void JobFilm::restore(Checkpoint checkpoint, bool keepFilm) {
    forget();
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
    const uint64_t samples =
        uint64_t(unit.tile.width()) * unit.tile.height() * (unit.passEnd - unit.passBegin);
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
    writeCheckpoint(m_path, copy.film, copy.merged);
}

Checkpoint JobFilm::readFile() const {
    return readCheckpoint(m_path, m_grid.width(), m_grid.height(), m_grid.unitCount());
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
    if (film.targetError())
        status.set_projected_passes(projectedPasses(*estimate, *film.targetError()));
}

}  // namespace alphorn::coordinator
