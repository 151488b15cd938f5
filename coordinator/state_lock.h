// An exclusive lock on a coordinator's state directory. Two coordinators on one directory would
// both resume its jobs and overwrite each other's checkpoints, so the second one must not start.
#pragma once

#include <string>

namespace alphorn::coordinator {

class StateDirectoryLock {
  public:
    // Creates `directory` if needed and takes the lock: flock on the directory itself, which
    // nobody can remove or replace while the coordinator uses it (a lock on a file in it was
    // lost when someone deleted the file, and a second coordinator then ran beside the first),
    // and flock on DIRECTORY/lock too, the file earlier versions lock. The kernel releases both
    // when the process dies. DIRECTORY/lock names the holder (pid, host, start time) for the
    // refusal's message. Throws Error naming the holder when another process, or another lock
    // object of this one, has it.
    explicit StateDirectoryLock(const std::string& directory);
    ~StateDirectoryLock();
    StateDirectoryLock(const StateDirectoryLock&) = delete;
    StateDirectoryLock& operator=(const StateDirectoryLock&) = delete;

  private:
    int m_directoryFd = -1;
    int m_fileFd = -1;
};

}  // namespace alphorn::coordinator
