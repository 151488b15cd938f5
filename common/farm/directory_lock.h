// An exclusive lock on a daemon's directory. Two coordinators on one state directory would both
// resume its jobs and overwrite each other's checkpoints; two workers on one cache directory
// would write, verify and remove each other's half-written blobs and job scenes, failing units
// (each failure an attempt counted against its job). So the second one must not start.
#pragma once

#include <string>

namespace alphorn::farm {

// Who locks what, for the refusal's message: "the state directory DIR is in use by another
// coordinator (...); stop that one first or give this one another --state-dir".
struct DirectoryLockRole {
    std::string directoryKind;  // "state directory"
    std::string daemon;         // "coordinator"
    std::string option;         // "--state-dir"
};

class DirectoryLock {
  public:
    // Creates `directory` if needed and takes the lock: flock on the directory itself, which
    // nobody can remove or replace while the daemon uses it (a lock on a file in it was lost
    // when someone deleted the file, and a second coordinator then ran beside the first), and
    // flock on DIRECTORY/lock too, the file earlier coordinators lock. The kernel releases both
    // when the process dies. DIRECTORY/lock names the holder (pid, host, start time) for the
    // refusal's message. Throws Error naming the holder when another process, or another lock
    // object of this one, has it.
    DirectoryLock(const std::string& directory, DirectoryLockRole role);
    ~DirectoryLock();
    DirectoryLock(const DirectoryLock&) = delete;
    DirectoryLock& operator=(const DirectoryLock&) = delete;

  private:
    int m_directoryFd = -1;
    int m_fileFd = -1;
};

}  // namespace alphorn::farm
