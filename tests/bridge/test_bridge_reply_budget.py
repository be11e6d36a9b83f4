"""The reply budget: undroppable answers a client leaves unread, bounded by closing it."""

from __future__ import annotations

from bridge.reply_budget import ReplyBudget


def test_within_the_budget_answers_are_only_counted():
    budget = ReplyBudget(limit_bytes=1000)
    assert all(budget.charge(100) for _ in range(10))
    assert (budget.waiting_bytes, budget.waiting_items) == (1000, 10)
    assert not budget.charge(1)
    assert "MiB of replies unread" in budget.reason() and len(budget.reason()) <= 123


def test_written_answers_free_the_budget():
    budget = ReplyBudget(limit_bytes=1000)
    for _ in range(10):
        assert budget.charge(400)
        budget.credit(400)
    assert (budget.waiting_bytes, budget.waiting_items) == (0, 0)


def test_one_answer_larger_than_the_budget_passes_alone():
    """A single big request forwarded to a provider must not close the provider."""
    budget = ReplyBudget(limit_bytes=1000)
    assert budget.charge(50_000)
    assert not budget.charge(10)
