"""subscriptions.py -- asyncua's subscription service, extended where the server must do more than
asyncua does (docs/opcua.md "Subscriptions", "Limits"):

- publishing intervals are revised up to min_publishing_interval_ms; subscriptions are bounded per
  session and in all (BadTooManySubscriptions);
- sampling intervals are revised as sampling.py runs them (a multiple of the basic period, at least
  min_sampling_interval_ms); monitored items of shared variables are fed by the Sampler instead of
  the address space's write callbacks;
- at most max_notifications_per_publish data changes go in one NotificationMessage (MoreNotifications
  set while more wait);
- queue sizes follow the spec (0 and 1: one value; at most max_queue_size), with discardOldest and
  the Overflow bit of the StatusCode's InfoBits on the value next to the one discarded;
- monitored items are bounded per call (BadTooManyOperations), per session and in all
  (BadTooManyMonitoredItems on each item over).
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import TYPE_CHECKING, Protocol

from asyncua import ua
from asyncua.common.utils import ServiceError
from asyncua.server.internal_subscription import InternalSubscription
from asyncua.server.monitored_item_service import MonitoredItemService
from asyncua.server.subscription_service import SubscriptionService

from .sampling import Item
from .values import index_range

if TYPE_CHECKING:
    from .address_space import Space
    from .sampling import Sampler
    from .settings import OpcuaSettings

OVERFLOW = 0x0480  # InfoType DataValue (0x400) | Overflow (0x80): a value was discarded before this one
HANDLES = itertools.count(1 << 40)  # the Sampler's handles, apart from the address space's


class Runtime(Protocol):
    """What the subscriptions take from the server's parts (server.py's Runtime has them): the
    settings' bounds, the Sampler that feeds shared variables, the nodes of those variables, and
    the service itself, whose counts bound a session's monitored items."""

    settings: OpcuaSettings
    sampler: Sampler
    space: Space
    subscriptions: Subscriptions


class Subscriptions(SubscriptionService):
    def __init__(self, aspace, iserver, runtime: Runtime):
        super().__init__(aspace, iserver=iserver)
        self.runtime = runtime

    def of_session(self, session_id: ua.NodeId) -> list[InternalSubscription]:
        return [s for s in self.subscriptions.values() if s.session_id == session_id]

    def item_counts(self, session_id: ua.NodeId) -> tuple[int, int]:
        """(monitored items of this session, monitored items in all)."""
        mine = total = 0
        for s in self.subscriptions.values():
            n = len(s.monitored_item_srv._monitored_items)
            total += n
            if s.session_id == session_id:
                mine += n
        return mine, total

    async def create_subscription(self, params, callback, session_id, request_callback=None):
        s = self.runtime.settings
        if len(self.subscriptions) >= s.max_subscriptions or len(self.of_session(session_id)) >= (
            s.max_subscriptions_per_session
        ):
            raise ServiceError(ua.StatusCodes.BadTooManySubscriptions)
        result = ua.CreateSubscriptionResult()
        result.RevisedPublishingInterval = max(float(params.RequestedPublishingInterval), s.min_publishing_interval_ms)
        result.RevisedLifetimeCount = self._clamp_lifetime_count(params.RequestedLifetimeCount)
        result.RevisedMaxKeepAliveCount = self._clamp_keep_alive_count(params.RequestedMaxKeepAliveCount)
        if result.RevisedLifetimeCount < 3 * result.RevisedMaxKeepAliveCount:  # the spec's rule
            result.RevisedLifetimeCount = 3 * result.RevisedMaxKeepAliveCount
        self._sub_id_counter += 1
        result.SubscriptionId = self._sub_id_counter
        requested = int(params.MaxNotificationsPerPublish or 0)
        sub = Subscription(
            result,
            self.aspace,
            callback,
            session_id,
            runtime=self.runtime,
            request_callback=request_callback,
            delete_callback=lambda: self.subscriptions.pop(result.SubscriptionId, None),
            no_acks_limit=self.iserver.max_unacked_messages_per_subscription,
            max_queue_size=s.max_queue_size,
            publishing_enabled=params.PublishingEnabled,
        )
        sub.max_notifications = (
            min(requested, s.max_notifications_per_publish) if requested else s.max_notifications_per_publish
        )
        await sub.start()
        self.subscriptions[result.SubscriptionId] = sub
        return result

    async def create_monitored_items(self, params):
        if len(params.ItemsToCreate) > self.runtime.settings.max_monitored_items_per_call:
            raise ServiceError(ua.StatusCodes.BadTooManyOperations)
        return await super().create_monitored_items(params)

    def modify_monitored_items(self, params):
        if len(params.ItemsToModify) > self.runtime.settings.max_monitored_items_per_call:
            raise ServiceError(ua.StatusCodes.BadTooManyOperations)
        return super().modify_monitored_items(params)


class Subscription(InternalSubscription):
    def __init__(self, *args, runtime: Runtime, **kwargs):
        super().__init__(*args, **kwargs)
        self.monitored_item_srv = MonitoredItems(self, self.monitored_item_srv.aspace, runtime)
        self.max_notifications = runtime.settings.max_notifications_per_publish

    def _pop_triggered_datachanges(self, result) -> None:
        """At most max_notifications data changes per NotificationMessage (the client's
        MaxNotificationsPerPublish, and the server's own bound, which keeps a message under the
        size a client accepts); the rest wait for the next publish, oldest first."""
        taken: list = []
        for mid in list(self._triggered_datachanges):
            queue = self._triggered_datachanges[mid]
            part = queue[: self.max_notifications - len(taken)]
            taken += part
            if len(part) == len(queue):
                del self._triggered_datachanges[mid]
            else:
                del queue[: len(part)]
            if len(taken) >= self.max_notifications:
                break
        if taken:
            result.NotificationMessage.NotificationData.append(ua.DataChangeNotification(MonitoredItems=taken))

    def _pop_publish_result(self):
        result = super()._pop_publish_result()
        result.MoreNotifications = bool(self._triggered_datachanges)
        return result

    async def enqueue_datachange_event(self, mid, eventdata, maxsize) -> None:
        """The spec's queue (Part 4, 5.12.1.5): full, discardOldest drops the oldest value and sets
        Overflow on the oldest one kept; else the newest queued is replaced and gets Overflow.  A
        queue of one holds the newest value, without the bit."""
        queue = self._triggered_datachanges.get(mid)
        if queue is None:
            self._triggered_datachanges[mid] = [eventdata]
            await self._trigger_publish()
            return
        size = max(1, maxsize)
        if len(queue) < size:
            queue.append(eventdata)
            return
        if size == 1:
            queue[0] = eventdata
            return
        mdata = self.monitored_item_srv._monitored_items.get(mid)
        if getattr(mdata, "discard_oldest", True):
            queue.pop(0)
            queue.append(eventdata)
            flagged = queue[0]
        else:
            queue[-1] = eventdata
            flagged = eventdata
        dv = flagged.Value
        code = dv.StatusCode.value if dv.StatusCode is not None else 0
        flagged.Value = dataclasses.replace(dv, StatusCode=ua.StatusCode(code | OVERFLOW))


class MonitoredItems(MonitoredItemService):
    def __init__(self, isub: Subscription, aspace, runtime: Runtime):
        super().__init__(isub, aspace)
        self.runtime = runtime

    # ---- revising -----------------------------------------------------------------------------
    def _revised_interval(self, requested: float) -> float:
        s = self.runtime.settings
        return self.runtime.sampler.revise(
            float(requested),
            self.isub.data.RevisedPublishingInterval,
            s.min_sampling_interval_ms,
            s.max_sampling_interval_ms,
        )

    def _revise_queue_size(self, requested: int) -> int:
        return min(max(1, int(requested)), self.isub.max_queue_size)

    def _make_monitored_item_common(self, params):
        result, mdata = super()._make_monitored_item_common(params)
        result.RevisedSamplingInterval = self._revised_interval(params.RequestedParameters.SamplingInterval)
        mdata.discard_oldest = bool(params.RequestedParameters.DiscardOldest)
        return result, mdata

    # ---- creating, changing, deleting ---------------------------------------------------------
    async def create_monitored_items(self, params):
        s = self.runtime.settings
        mine, total = self.runtime.subscriptions.item_counts(self.isub.session_id)
        results = []
        for item in params.ItemsToCreate:
            if mine >= s.max_monitored_items_per_session or total >= s.max_monitored_items:
                results.append(
                    ua.MonitoredItemCreateResult(StatusCode=ua.StatusCode(ua.StatusCodes.BadTooManyMonitoredItems))
                )
                continue
            if item.ItemToMonitor.AttributeId == ua.AttributeIds.EventNotifier:
                result = self._create_events_monitored_item(item)
            else:
                result = await self._create_data_change_monitored_item(item)
            if result.StatusCode.is_good():
                mine, total = mine + 1, total + 1
            results.append(result)
        return results

    async def _create_data_change_monitored_item(self, params):
        ref = params.ItemToMonitor
        var = self.runtime.space.var_of(ref.NodeId) if ref.AttributeId == ua.AttributeIds.Value else None
        if var is None:
            return await super()._create_data_change_monitored_item(params)
        picked = None
        if ref.IndexRange:  # elements of a 1-D array: sampled as variables of their own
            picked = index_range(ref.IndexRange, len(var.leaves)) if len(var.dims) == 1 else None
            if picked is None:
                return ua.MonitoredItemCreateResult(StatusCode=ua.StatusCode(ua.StatusCodes.BadIndexRangeInvalid))
        result, mdata = self._make_monitored_item_common(params)
        handle = next(HANDLES)
        mdata.callback_handle = handle
        self._commit_monitored_item(result, mdata)
        self._monitored_datachange[handle] = result.MonitoredItemId
        item = Item(handle, var, result.RevisedSamplingInterval, self.deliver, picked)
        sampler = self.runtime.sampler
        sampler.add(item)
        if mdata.mode != ua.MonitoringMode.Disabled:
            await self.deliver(handle, sampler.prime(item))
        return result

    def _modify_monitored_item(self, params):
        result = ua.MonitoredItemModifyResult()
        mdata = self._monitored_items.get(params.MonitoredItemId)
        if mdata is None:
            result.StatusCode = ua.StatusCode(ua.StatusCodes.BadMonitoredItemIdInvalid)
            return result
        requested = params.RequestedParameters
        result.RevisedSamplingInterval = self._revised_interval(requested.SamplingInterval)
        result.RevisedQueueSize = self._revise_queue_size(requested.QueueSize)
        mdata.client_handle = requested.ClientHandle
        mdata.filter = requested.Filter
        mdata.queue_size = result.RevisedQueueSize
        mdata.discard_oldest = bool(requested.DiscardOldest)
        self.runtime.sampler.change(mdata.callback_handle, result.RevisedSamplingInterval)
        return result

    def _delete_monitored_items(self, mid: int) -> ua.StatusCode:
        mdata = self._monitored_items.get(mid)
        if mdata is not None and mdata.callback_handle is not None:
            self.runtime.sampler.remove(mdata.callback_handle)
        return super()._delete_monitored_items(mid)

    # ---- values in ----------------------------------------------------------------------------
    async def deliver(self, handle: int, dv: ua.DataValue) -> None:
        """A value the Sampler took for the item: queued as it is (the Sampler hands changes only),
        or through asyncua's filter when the item has one (a deadband)."""
        mid = self._monitored_datachange.get(handle)
        mdata = self._monitored_items.get(mid) if mid is not None else None
        if mdata is None or mdata.mode != ua.MonitoringMode.Reporting:
            return
        if mdata.filter is not None:
            await self.datachange_callback(handle, dv)
            return
        mdata.mvalue.current_dvalue = dv
        notification = ua.MonitoredItemNotification(ClientHandle=mdata.client_handle, Value=dv)
        await self.isub.enqueue_datachange_event(mid, notification, mdata.queue_size)
