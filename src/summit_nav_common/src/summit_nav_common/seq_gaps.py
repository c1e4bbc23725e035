"""Counting the messages a subscriber never saw, from the publisher's header.seq.

A ROS publisher numbers the messages of a topic 1, 2, 3, ... in header.seq (rospy and
roscpp both do; rosbag play replays the recorded numbers). A subscriber whose queue is
full drops the oldest message silently, and so does a node that falls behind: a gap in
the numbers its callback sees is the count of messages lost on the way. This is the same
test that message_filters' and rqt's "dropped messages" statistics make.

SeqGaps.observe(seq) returns how many messages were skipped just before this one. A
number that goes back (the publisher restarted, a bag looped) starts counting afresh
rather than counting a gap; a publisher that leaves seq at 0 is never counted.
SeqGaps.drop() counts a message that arrived but that the node gave up before using it
(a queue of its own was full): lost all the same, so it is in `skipped` too.
"""


class SeqGaps:
    """received: messages seen; skipped: messages lost between those seen or dropped
    after they were seen (dropped: those of them)."""

    def __init__(self):
        self.received = 0
        self.skipped = 0
        self.dropped = 0
        self.last = None   # the last header.seq seen

    def drop(self) -> None:
        """Count one message that was received and then given up unused."""
        self.dropped += 1
        self.skipped += 1

    def observe(self, seq: int) -> int:
        """Count one message numbered seq; returns the messages skipped just before it."""
        seq = int(seq)
        self.received += 1
        gap = 0
        if self.last is not None and seq > self.last:
            gap = seq - self.last - 1
        self.skipped += gap
        self.last = seq
        return gap
